"""The authoritative state of a wall and the one function that changes it.

Tiles are pure renderers: they draw the state they are sent. Every change goes
through the door (``webapp.changes.door``) to :func:`commit_change`, which bumps the wall's
version and persists the new state with the event that describes it; only then is the
event published.

The state holds the core's fields and one slot per app (``apps``): an app keeps what
only it shows there, as an :class:`AppState` model it owns; the core never reads a slot.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, ClassVar, Literal, Self

from pydantic import BaseModel, ConfigDict, Field, model_validator
from sqlalchemy import bindparam, delete, select, update
from sqlalchemy.exc import IntegrityError, OperationalError
from sqlalchemy.orm import Session

from webapp.database.connection import Database
from webapp.database.models import WallEventRecord, WallStateRecord

TransferName = Literal["grey", "tissue", "hot"]
"""The colour presets of a volume (their tables: ``webapp.volume.transfer``)."""
VolumeMode = Literal["composite", "mip", "slice"]
Interval = tuple[float, float]


class VolumeLayer(BaseModel):
    """A volume drawn across the wall: its store name, render mode, colours and clipping.

    A core layer, not an app's: the core renders volumes for whichever app shows one
    (the brain atlas its template, the test pattern a stored volume). Its orientation,
    centre and zoom are the wall's ``view``; changing the layer is a heavy change."""

    model_config = ConfigDict(extra="forbid")

    volume: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    mode: VolumeMode = "composite"
    transfer: TransferName = "grey"
    # the part of the volume kept, as fractions of its extent along x, y and z
    clip: tuple[Interval, Interval, Interval] = ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))
    # slice mode: the plane's distance from the centre along the view direction, as a
    # fraction of half the volume's diagonal (0 = through the centre)
    slice: float = Field(default=0.0, ge=-1.0, le=1.0)

    @model_validator(mode="after")
    def _clip_intervals(self) -> VolumeLayer:
        for axis, (low, high) in zip("xyz", self.clip, strict=True):
            if not 0.0 <= low < high <= 1.0:
                raise ValueError(f"clip along {axis} must satisfy 0 <= low < high <= 1")
        return self


class View(BaseModel):
    """Where the scene looks: centre as a fraction of the wall's stage, zoom, orientation."""

    model_config = ConfigDict(extra="forbid")

    center: tuple[float, float] = (0.5, 0.5)
    zoom: float = Field(default=1.0, gt=0, le=1_000)
    yaw: float = Field(default=0.0, ge=-360, le=360)
    pitch: float = Field(default=0.0, ge=-90, le=90)


class Balloon(BaseModel):
    """A description balloon open on the wall, pointing at an anchor (scene mm).

    ``rect`` is where the box stands (placed by the server clear of codes and other
    balloons); tiles stop drawing it at ``closes_at`` on the shared clock.
    """

    model_config = ConfigDict(extra="forbid")

    id: str = Field(min_length=1, max_length=64)
    anchor: tuple[float, float]
    rect: tuple[float, float, float, float] | None = None  # x, y, width, height
    title: str = Field(max_length=200)
    lines: list[str] = Field(default_factory=list, max_length=20)
    closes_at: int | None = None  # server ms

    def open_at(self, ms: int) -> bool:
        return self.closes_at is None or self.closes_at > ms


class PublicItem(BaseModel):
    """What the public screen shows: server-rendered, already escaped HTML
    (see ``webapp.publishing.publication``)."""

    model_config = ConfigDict(extra="forbid")

    id: int = Field(default=0, ge=0)  # the publication's id (0: not a stored one)
    title: str = Field(max_length=200)
    html: str = Field(max_length=100_000)
    author: str = Field(max_length=100)
    published_at: int  # server ms


class PublicPolicy(BaseModel):
    """How the public screen takes publications: held for approval, or locked."""

    model_config = ConfigDict(extra="forbid")

    moderated: bool = False  # students' publications wait for an instructor
    locked: bool = False  # only instructors may publish


class WallState(BaseModel):
    """Everything a tile needs to draw its part of the wall."""

    model_config = ConfigDict(extra="forbid")

    app: str = Field(default="", max_length=64)  # "": none yet (the first app comes at start)
    mode: str = Field(default="default", min_length=1, max_length=64)
    view: View = Field(default_factory=View)
    layers: dict[str, bool] = Field(default_factory=dict)
    balloons: list[Balloon] = Field(default_factory=list, max_length=100)
    public: PublicItem | None = None
    public_policy: PublicPolicy = Field(default_factory=PublicPolicy)
    tag_set: str | None = Field(default=None, max_length=64)
    tag_layout: int = Field(default=0, ge=0)  # the placed codes tiles draw (0: none yet)
    volume: VolumeLayer | None = None  # a volume drawn across the wall (None: none)
    apps: dict[str, dict[str, Any]] = Field(default_factory=dict)
    """Each app's slot (its :class:`AppState`, as JSON), by app name."""


class AppState(BaseModel):
    """An app's slot in the wall state: an app subclasses it with the fields it keeps.

    The app owns the model and versions it: a slot is stored with its ``version`` and
    read through :meth:`upgrade`, so an app can change its fields without the core.
    ``heavy`` names the fields whose change makes tiles fetch something first (prepare,
    ready, swap); ``placing`` those that move codes (the door places the tags again)."""

    model_config = ConfigDict(extra="forbid")

    app: ClassVar[str]
    version: ClassVar[int] = 1
    heavy: ClassVar[frozenset[str]] = frozenset()
    placing: ClassVar[frozenset[str]] = frozenset()

    @classmethod
    def of(cls, state: WallState) -> Self:
        """The app's slot of ``state`` (its defaults when the app never kept anything)."""
        stored = dict(state.apps.get(cls.app, {}))
        version = stored.pop("version", cls.version)
        return cls.model_validate(
            cls.upgrade(stored, version) if version != cls.version else stored
        )

    @classmethod
    def upgrade(cls, stored: dict[str, Any], version: int) -> dict[str, Any]:
        """A slot stored by ``version`` of the model, as this version reads it."""
        raise ValueError(f"{cls.app}: no upgrade from slot version {version} to {cls.version}")

    def put(self, state: WallState) -> WallState:
        """``state`` with this slot in it."""
        slot = {**self.model_dump(mode="json"), "version": self.version}
        return state.model_copy(update={"apps": {**state.apps, self.app: slot}})

    @classmethod
    def keys(cls) -> tuple[frozenset[str], frozenset[str]]:
        """The heavy and placing keys of the slot, as :func:`changed_keys` names them."""
        return (
            frozenset(f"{cls.app}.{name}" for name in cls.heavy),
            frozenset(f"{cls.app}.{name}" for name in cls.placing),
        )


class StatePatch(BaseModel):
    """A partial state: the fields given replace the current ones; ``volume`` alone may
    be null (it takes the volume off the wall), other fields are left out to keep them."""

    model_config = ConfigDict(extra="forbid")

    app: str | None = Field(default=None, min_length=1, max_length=64)
    mode: str | None = Field(default=None, min_length=1, max_length=64)
    view: View | None = None
    layers: dict[str, bool] | None = None
    balloons: list[Balloon] | None = Field(default=None, max_length=100)
    # ``public`` changes only through ``webapp.publishing.screen``, which renders it safely.
    public_policy: PublicPolicy | None = None
    volume: VolumeLayer | None = None  # null takes the volume off the wall

    @model_validator(mode="after")
    def _only_volume_may_be_null(self) -> StatePatch:
        nulls = sorted(
            name for name in self.model_fields_set - {"volume"} if getattr(self, name) is None
        )
        if nulls:
            raise ValueError(f"{', '.join(nulls)} may not be null; leave a field out to keep it")
        return self

    def apply_to(self, state: WallState) -> WallState:
        """The state with this patch's fields replaced (``layers`` merge key by key)."""
        given = self.model_dump(exclude_unset=True)
        if "layers" in given and given["layers"] is not None:
            given["layers"] = {**state.layers, **given["layers"]}
        return state.model_validate({**state.model_dump(), **given})


class Change(BaseModel):
    """A committed change: the new version and the fields that changed (the core's by
    name; ``apps`` with, per app, only the keys of its slot that changed)."""

    wall_id: str
    version: int
    changes: dict[str, Any]
    heavy: bool


CORE_HEAVY_KEYS = frozenset({"app", "view", "tag_set", "tag_layout", "volume"})
"""The core's fields whose change makes tiles fetch something (renders, code layouts)
first: applied by prepare -> ready -> swap. Apps add theirs (:meth:`AppState.keys`)."""
CORE_PLACING_KEYS = frozenset({"app", "view", "volume", "tag_set"})
"""The core's fields that decide which codes stand where. Apps add theirs."""


def state_changes(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """What changed from ``old`` to ``new`` (states as JSON): each core field that
    changed, and under ``apps`` each changed slot with only its changed keys."""
    changes = {k: v for k, v in new.items() if k != "apps" and old.get(k) != v}
    old_apps, new_apps = old.get("apps", {}), new.get("apps", {})
    apps = {}
    for name, slot in new_apps.items():
        before = old_apps.get(name, {})
        if changed := {k: v for k, v in slot.items() if before.get(k) != v}:
            apps[name] = changed
    if apps:
        changes["apps"] = apps
    return changes


def differing_keys(old: WallState, new: WallState) -> set[str]:
    """The keys that differ between two states, named as :func:`changed_keys` names them,
    read from the models (no JSON: the door asks this of every change)."""
    keys = {n for n in WallState.model_fields if n != "apps" and getattr(old, n) != getattr(new, n)}
    for name in old.apps.keys() | new.apps.keys():
        before, after = old.apps.get(name, {}), new.apps.get(name, {})
        keys.update(
            f"{name}.{k}" for k in before.keys() | after.keys() if before.get(k) != after.get(k)
        )
    return keys


def differing_fields(state: WallState, other: WallState) -> dict[str, Any]:
    """The fields of ``state`` that differ from ``other``'s, as an update of ``other``."""
    return {
        name: getattr(state, name)
        for name in WallState.model_fields
        if getattr(state, name) != getattr(other, name)
    }


def changed_keys(changes: dict[str, Any]) -> set[str]:
    """The keys of a change: core fields by name, app slot keys as ``app.key``."""
    keys = {k for k in changes if k != "apps"}
    keys.update(f"{name}.{k}" for name, slot in changes.get("apps", {}).items() for k in slot)
    return keys


_MAX_RETRIES = 20


def now_ms() -> int:
    """Server time in milliseconds: the clock every tile synchronises to."""
    return time.time_ns() // 1_000_000


_STATE_OF_WALL = select(WallStateRecord.version, WallStateRecord.state).where(
    WallStateRecord.wall_id == bindparam("wall_id")
)
"""Every page of a phone reads it: built once (see :meth:`Database.reading`)."""


def read_state(db: Database, wall_id: str) -> tuple[int, WallState]:
    """The wall's current version and state (version 0 and defaults if never changed)."""
    with db.reading() as connection:
        row = connection.execute(_STATE_OF_WALL, {"wall_id": wall_id}).first()
    if row is None:
        return 0, WallState()
    return row.version, WallState.model_validate(row.state)


def events_since(db: Database, wall_id: str, version: int) -> list[Change] | None:
    """The changes after ``version`` in order, or None when a snapshot is needed instead.

    A snapshot is needed when the history no longer reaches back that far, and when
    the client claims a version from the future (the database was reset or swapped).
    """
    with db.session() as session:
        current = session.scalar(
            select(WallStateRecord.version).where(WallStateRecord.wall_id == wall_id)
        )
        current = current or 0
        if version > current:
            return None
        if version == current:
            return []
        rows = session.scalars(
            select(WallEventRecord)
            .where(WallEventRecord.wall_id == wall_id, WallEventRecord.version > version)
            .order_by(WallEventRecord.version)
        ).all()
    if len(rows) != current - version:
        return None
    return [
        Change(wall_id=wall_id, version=r.version, changes=r.changes, heavy=r.heavy) for r in rows
    ]


def commit_change(
    db: Database,
    wall_id: str,
    update_state: Callable[[WallState], WallState],
    *,
    keep_events: int,
    heavy_keys: frozenset[str] = CORE_HEAVY_KEYS,
) -> Change | None:
    """Persist ``update_state(current)`` as the next version; None if nothing changed.
    It is heavy when one of ``heavy_keys`` changed.

    Optimistic concurrency: the version row is updated only if nobody else bumped
    it meanwhile, and (wall, version) is the events table's primary key, so two
    writers can never commit the same version; the loser retries on fresh state.
    """
    for attempt in range(_MAX_RETRIES):
        try:
            with db.session() as session:
                change = _try_commit(session, wall_id, update_state, keep_events, heavy_keys)
            return change
        except (IntegrityError, _StaleVersion):
            continue
        except OperationalError as error:
            if not _is_lock_conflict(error):
                raise
            time.sleep(0.005 * (attempt + 1))  # SQLite: another writer holds the lock
    raise RuntimeError(f"wall {wall_id!r}: too much contention to commit a change")


def _is_lock_conflict(error: OperationalError) -> bool:
    return "locked" in str(error.orig).lower() or "could not serialize" in str(error.orig)


class _StaleVersion(Exception):
    """Another writer bumped the version first."""


def _try_commit(
    session: Session,
    wall_id: str,
    update_state: Callable[[WallState], WallState],
    keep_events: int,
    heavy_keys: frozenset[str],
) -> Change | None:
    # Row lock where the database has one (PostgreSQL): concurrent writers queue up
    # instead of racing; the version check below still guards every backend.
    record = session.get(WallStateRecord, wall_id, with_for_update=True)
    version = record.version if record else 0
    old = WallState.model_validate(record.state) if record else WallState()
    new = update_state(old)
    old_fields, new_fields = old.model_dump(mode="json"), new.model_dump(mode="json")
    changes = state_changes(old_fields, new_fields)
    if not changes:
        return None
    heavy = bool(heavy_keys & changed_keys(changes))
    if record is None:
        session.add(WallStateRecord(wall_id=wall_id, version=1, state=new_fields))
        session.flush()
    else:
        result = session.execute(
            update(WallStateRecord)
            .where(WallStateRecord.wall_id == wall_id, WallStateRecord.version == version)
            .values(version=version + 1, state=new_fields)
            .execution_options(synchronize_session=False)
        )
        if result.rowcount != 1:  # type: ignore[attr-defined]
            raise _StaleVersion
    session.add(WallEventRecord(wall_id=wall_id, version=version + 1, changes=changes, heavy=heavy))
    session.execute(
        delete(WallEventRecord).where(
            WallEventRecord.wall_id == wall_id,
            WallEventRecord.version <= version + 1 - keep_events,
        )
    )
    return Change(wall_id=wall_id, version=version + 1, changes=changes, heavy=heavy)
