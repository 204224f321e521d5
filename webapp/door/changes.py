"""The one door for wall-state changes.

Everything that changes a wall — an operator's patch, a phone's toggle or balloon, a
publication, a tag-set switch, a tag issued or patched, the start of a server — goes
through here, and nothing else calls the hub's :meth:`~webapp.engine.hub.WallHub.commit`.
A change:

1. runs under the wall's placing lock, so two changes of one wall never interleave
   (a tag-set switch racing an app switch cannot leave codes that belong to another
   view);
2. lets an app leaving the wall take what only it shows (its volume) and an app
   coming on settle and bring its own tag set;
3. when it moves what codes stand on (:data:`PLACING_FIELDS`), has the apps on the wall
   declare their tags for the new state and places the set shown, so the codes arrive
   in the same swap as the scene;
4. drops the cached code look-ups when tags were declared or placed;
5. commits (bumping the version) and publishes to the tiles, through the hub.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import TYPE_CHECKING, Any

from wall_client.layout import Wall
from webapp.engine.wall_state import Change, WallState, read_state
from webapp.tags.registry import declare, layout_for

if TYPE_CHECKING:
    from webapp.apps.contract import WallApp
    from webapp.server.services import Services

Update = Callable[[WallState], WallState]
"""A change as a function of the state: applied to the state as it is at commit."""

PLACING_FIELDS = ("app", "view", "dataset", "volume", "tag_set", "quiz_round")
"""State fields that decide which codes stand where: changing one declares the apps'
tags again and places the set shown."""


def unchanged(state: WallState) -> WallState:
    return state


async def change_wall(
    services: Services, wall: Wall, update: Update, *, replace_codes: bool = False
) -> Change | None:
    """Change ``wall`` by ``update``; None when that changes nothing.

    ``replace_codes`` places the shown set again even when no placing field changes
    (after a tag of the wall was issued or patched).
    """

    async def plan(_current: WallState) -> Update:
        return update

    return await plan_change(services, wall, plan, replace_codes=replace_codes)


async def plan_change(
    services: Services,
    wall: Wall,
    plan: Callable[[WallState], Awaitable[Update]],
    *,
    replace_codes: bool = False,
) -> Change | None:
    """Like :func:`change_wall`, for a change that must look at the wall first (where
    a balloon fits among the codes shown): ``plan`` gets the current state, with the
    wall held, and returns the update."""
    async with services.hub.placing(wall.id):
        _, current = await services.hub.run_sync(read_state, services.db, wall.id)
        update = await plan(current)
        target = update(current)
        moves = any(getattr(target, f) != getattr(current, f) for f in PLACING_FIELDS)
        if not (moves or replace_codes):
            return await services.hub.commit(wall.id, update)
        placed = await services.hub.run_sync(_place_codes, services, wall, current, target)
        return await services.hub.commit(
            wall.id, lambda state: update(state).model_copy(update=placed)
        )


async def open_wall(services: Services, wall: Wall) -> Change | None:
    """Bring a wall up at server start: settle the app it shows, declare every app's
    tags and put the wall's tag set up.

    Idempotent: codes stay as they were and an unchanged set is not placed again, so
    every server process of a wall may do this at start.
    """
    async with services.hub.placing(wall.id):
        _, current = await services.hub.run_sync(read_state, services.db, wall.id)
        fields = await services.hub.run_sync(_opening_fields, services, wall, current)
        return await services.hub.commit(wall.id, lambda state: state.model_copy(update=fields))


def _place_codes(
    services: Services, wall: Wall, current: WallState, target: WallState
) -> dict[str, Any]:
    """The fields that put the right codes up for ``target``: what the app coming on
    the wall settles, and the tag set and its layout (runs in a worker thread)."""
    app = services.apps.get(target.app)
    leaving = services.apps.get(current.app) if current.app != target.app else None
    fields: dict[str, Any] = {}
    tag_set = target.tag_set
    if target.app != current.app:
        ready = leaving.leave(target) if leaving is not None else target
        if app is not None:
            tag_set = app.default_tag_set
            ready = app.settle(services, wall, ready)
        fields = {
            name: getattr(ready, name)
            for name in WallState.model_fields
            if getattr(ready, name) != getattr(target, name)
        }
        target = ready
    declaring = [a for a in (leaving, app) if a is not None]
    return {**fields, **_declare_and_place(services, wall, declaring, target, tag_set)}


def _opening_fields(services: Services, wall: Wall, current: WallState) -> dict[str, Any]:
    """What a wall's state needs at start (see :func:`open_wall`)."""
    state = current
    if (shown := services.apps.get(current.app)) is not None:
        state = shown.settle(services, wall, current)
    fields = {
        name: getattr(state, name)
        for name in WallState.model_fields
        if getattr(state, name) != getattr(current, name)
    }
    tag_set = state.tag_set
    if not state.tag_layout and shown is not None:
        tag_set = shown.default_tag_set
    apps = list(services.apps.values())
    return {**fields, **_declare_and_place(services, wall, apps, state, tag_set)}


def _declare_and_place(
    services: Services, wall: Wall, apps: list[WallApp], state: WallState, tag_set: str | None
) -> dict[str, Any]:
    """Declare the tags of ``apps`` for ``state``, then place ``tag_set``; the scan
    path's cached look-ups are dropped, since codes may have come or gone."""
    for app in apps:
        declare(services.db, wall.id, app.name, app.declare_tags(services, wall, state))
    layout_id = layout_for(services.db, wall, tag_set, services.base_url)
    services.codes.forget()
    return {"tag_set": tag_set, "tag_layout": layout_id}
