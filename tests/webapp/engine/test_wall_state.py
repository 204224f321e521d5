from concurrent.futures import ThreadPoolExecutor

import pytest
from pydantic import ValidationError

from tests.conftest import migrate
from webapp.database.connection import Database
from webapp.engine.wall_state import (
    StatePatch,
    View,
    WallState,
    commit_change,
    events_since,
    read_state,
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
