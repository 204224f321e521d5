from concurrent.futures import ThreadPoolExecutor
from typing import Any, ClassVar

import pytest
from pydantic import ValidationError

from tests.conftest import migrate
from webapp.database.connection import Database
from webapp.engine.wall_state import (
    CORE_HEAVY_KEYS,
    AppState,
    StatePatch,
    View,
    WallState,
    changed_keys,
    commit_change,
    differing_keys,
    events_since,
    read_state,
    state_changes,
)


@pytest.fixture
def db(database_url: str) -> Database:
    migrate(database_url)
    return Database(database_url)


def patch(**fields: object) -> StatePatch:
    return StatePatch.model_validate(fields)


def test_unchanged_wall_has_version_zero(db: Database) -> None:
    assert read_state(db, "demo") == (0, WallState())


def test_change_bumps_version_and_persists(db: Database) -> None:
    change = commit_change(db, "demo", patch(mode="quiz").apply_to, keep_events=100)
    assert change is not None
    assert (change.version, change.changes, change.heavy) == (1, {"mode": "quiz"}, False)
    version, state = read_state(Database(db.url), "demo")
    assert version == 1 and state.mode == "quiz"


def test_no_op_change_keeps_version(db: Database) -> None:
    commit_change(db, "demo", patch(mode="quiz").apply_to, keep_events=100)
    assert commit_change(db, "demo", patch(mode="quiz").apply_to, keep_events=100) is None
    assert read_state(db, "demo")[0] == 1


def test_view_and_app_changes_are_heavy(db: Database) -> None:
    view = View(center=(0.2, 0.3), zoom=2)
    change = commit_change(db, "demo", patch(view=view).apply_to, keep_events=100)
    assert change is not None and change.heavy
    assert change.changes == {"view": {"center": [0.2, 0.3], "zoom": 2.0, "yaw": 0.0, "pitch": 0.0}}


def test_layers_merge_key_by_key(db: Database) -> None:
    commit_change(db, "demo", patch(layers={"grid": False}).apply_to, keep_events=100)
    commit_change(db, "demo", patch(layers={"labels": False}).apply_to, keep_events=100)
    assert read_state(db, "demo")[1].layers == {"grid": False, "labels": False}


def test_replay_lists_missed_changes_in_order(db: Database) -> None:
    for mode in ("a", "b", "c"):
        commit_change(db, "demo", patch(mode=mode).apply_to, keep_events=100)
    replay = events_since(db, "demo", 1)
    assert replay is not None
    assert [(c.version, c.changes) for c in replay] == [(2, {"mode": "b"}), (3, {"mode": "c"})]
    assert events_since(db, "demo", 3) == []
    assert events_since(db, "demo", 7) is None  # a version from the future: snapshot


def test_replay_impossible_once_history_is_trimmed(db: Database) -> None:
    for index in range(6):
        commit_change(db, "demo", patch(mode=f"m{index}").apply_to, keep_events=3)
    assert events_since(db, "demo", 0) is None
    replay = events_since(db, "demo", 3)
    assert replay is not None and [c.version for c in replay] == [4, 5, 6]


def test_walls_are_independent(db: Database) -> None:
    commit_change(db, "a", patch(mode="x").apply_to, keep_events=100)
    assert read_state(db, "b") == (0, WallState())


def test_concurrent_writers_never_lose_a_change(db: Database) -> None:
    def toggle(index: int) -> None:
        commit_change(db, "demo", patch(layers={f"layer{index}": True}).apply_to, keep_events=500)

    with ThreadPoolExecutor(max_workers=6) as pool:
        list(pool.map(toggle, range(40)))
    version, state = read_state(db, "demo")
    assert version == 40
    assert state.layers == {f"layer{index}": True for index in range(40)}
    replay = events_since(db, "demo", 0)
    assert replay is not None and [c.version for c in replay] == list(range(1, 41))


@pytest.mark.parametrize(
    "fields",
    [
        {"colour": "red"},
        {"view": {"zoom": 0}},
        {"view": {"zoom": "big"}},
        {"view": {"center": [0.5]}},
        {"mode": ""},
        {"layers": {"grid": "maybe"}},
    ],
)
def test_malformed_patches_are_rejected(fields: dict[str, object]) -> None:
    with pytest.raises(ValidationError):
        StatePatch.model_validate(fields)


def test_failed_update_leaves_state_intact(db: Database) -> None:
    commit_change(db, "demo", patch(mode="kept").apply_to, keep_events=100)

    def broken(state: WallState) -> WallState:
        raise ValueError("boom")

    with pytest.raises(ValueError):
        commit_change(db, "demo", broken, keep_events=100)
    assert read_state(db, "demo") == (1, WallState(mode="kept"))


class Lamp(AppState):
    """An app's slot as a test keeps it: a colour (heavy) and a code's place (placing)."""

    app: ClassVar[str] = "lamp"
    version: ClassVar[int] = 2
    heavy: ClassVar[frozenset[str]] = frozenset({"colour"})
    placing: ClassVar[frozenset[str]] = frozenset({"spot"})

    colour: str = "white"
    spot: int = 0

    @classmethod
    def upgrade(cls, stored: dict[str, Any], version: int) -> dict[str, Any]:
        return {"colour": stored["hue"]} if version == 1 else super().upgrade(stored, version)


def test_an_apps_slot_reads_its_defaults_until_the_app_keeps_something() -> None:
    assert Lamp.of(WallState()) == Lamp()
    state = Lamp(colour="red").put(WallState())
    assert state.apps == {"lamp": {"colour": "red", "spot": 0, "version": 2}}
    assert Lamp.of(state).colour == "red"


def test_a_slot_stored_by_an_earlier_version_is_read_through_the_apps_upgrade() -> None:
    old = WallState(apps={"lamp": {"hue": "blue", "version": 1}})
    assert Lamp.of(old) == Lamp(colour="blue")
    with pytest.raises(ValueError, match="no upgrade from slot version 7"):
        Lamp.of(WallState(apps={"lamp": {"version": 7}}))


def test_a_change_carries_only_the_slot_keys_that_changed_named_by_their_app() -> None:
    old = Lamp(colour="red").put(WallState())
    new = Lamp(colour="red", spot=3).put(WallState(mode="x"))
    assert differing_keys(old, new) == {"mode", "lamp.spot"}  # what the door asks
    changes = state_changes(old.model_dump(mode="json"), new.model_dump(mode="json"))
    assert changes == {"mode": "x", "apps": {"lamp": {"spot": 3}}}
    assert changed_keys(changes) == {"mode", "lamp.spot"}
    assert Lamp.keys() == (frozenset({"lamp.colour"}), frozenset({"lamp.spot"}))


def test_a_commit_is_heavy_when_an_apps_heavy_key_changes(db: Database) -> None:
    heavy = CORE_HEAVY_KEYS | Lamp.keys()[0]
    appeared = commit_change(db, "w", Lamp().put, keep_events=10, heavy_keys=heavy)
    assert appeared is not None and appeared.heavy  # a new slot: every key of it is new
    moved = commit_change(db, "w", Lamp(spot=1).put, keep_events=10, heavy_keys=heavy)
    assert moved is not None and not moved.heavy
    assert moved.changes == {"apps": {"lamp": {"spot": 1}}}

    def colour(state: WallState) -> WallState:
        return Lamp.of(state).model_copy(update={"colour": "red"}).put(state)

    coloured = commit_change(db, "w", colour, keep_events=10, heavy_keys=heavy)
    assert coloured is not None and coloured.heavy
    assert coloured.changes == {"apps": {"lamp": {"colour": "red"}}}
