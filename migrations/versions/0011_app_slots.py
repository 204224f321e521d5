"""Apps keep their state in slots of their own: the census map's data set and colouring
and the brain's quiz round move from the wall state's top level into ``apps``.

Stored states and the event history (which tiles replay to catch up) move alike. Tiles
read the slots with the new pages only: reload every kiosk after the upgrade (a tile that
kept the old page open would miss the census map's changes). A state that never named
its app showed the test pattern (the old default): it now says so.

Revision ID: 0011
Revises: 0010
Create Date: 2026-11-27
"""

from collections.abc import Sequence
from typing import Any

import sqlalchemy as sa
from alembic import op

revision: str = "0011"
down_revision: str | None = "0010"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

SLOTS = {"census": ("dataset", "theme"), "brain": ("quiz_round",)}
"""Each app's slot and the top-level fields it takes."""
SLOT_VERSION = 1

states = sa.table("wall_states", sa.column("wall_id", sa.String), sa.column("state", sa.JSON))
events = sa.table(
    "wall_events",
    sa.column("wall_id", sa.String),
    sa.column("version", sa.Integer),
    sa.column("changes", sa.JSON),
)


def _into_slots(fields: dict[str, Any], *, whole: bool) -> dict[str, Any]:
    """``fields`` with the apps' fields moved into their slots (``whole``: a state,
    whose slots carry their version; else a change, with the changed keys only)."""
    moved = dict(fields)
    apps: dict[str, Any] = dict(moved.pop("apps", None) or {})
    for app, names in SLOTS.items():
        taken = {name: moved.pop(name) for name in names if name in moved}
        if whole and any(value is not None for value in taken.values()):
            apps[app] = {**taken, "version": SLOT_VERSION}
        elif not whole and taken:
            apps[app] = {**apps.get(app, {}), **taken}
    if whole or apps:
        moved["apps"] = apps
    return moved


def _out_of_slots(fields: dict[str, Any]) -> dict[str, Any]:
    moved = dict(fields)
    apps = moved.pop("apps", None) or {}
    for app, names in SLOTS.items():
        slot = apps.get(app, {})
        moved.update({name: slot[name] for name in names if name in slot})
    return moved


def _rewrite(change: Any) -> None:
    connection = op.get_bind()
    for wall_id, state in connection.execute(sa.select(states.c.wall_id, states.c.state)).all():
        connection.execute(
            states.update().where(states.c.wall_id == wall_id).values(state=change(state, True))
        )
    rows = connection.execute(sa.select(events.c.wall_id, events.c.version, events.c.changes))
    for wall_id, version, changes in rows.all():
        connection.execute(
            events.update()
            .where(events.c.wall_id == wall_id, events.c.version == version)
            .values(changes=change(changes, False))
        )


def upgrade() -> None:
    def change(fields: dict[str, Any], whole: bool) -> dict[str, Any]:
        moved = _into_slots(fields, whole=whole)
        if whole and not moved.get("app"):
            moved["app"] = "pattern"
        return moved

    _rewrite(change)


def downgrade() -> None:
    def change(fields: dict[str, Any], whole: bool) -> dict[str, Any]:
        moved = _out_of_slots(fields)
        if whole and not moved.get("app"):
            moved["app"] = "pattern"  # the old state required an app
        return moved

    _rewrite(change)
