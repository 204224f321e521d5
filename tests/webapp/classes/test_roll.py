"""A class at a wall and its roll, as stored."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from zoneinfo import ZoneInfo

import pytest

from webapp.classes.roll import (
    MAX_NAME,
    ClassError,
    class_at,
    end_class,
    get_class,
    join,
    joined_count,
    latest_class,
    roll_names,
    running_class,
    standing,
    start_class,
)
from webapp.database.connection import Database

WALL = "demo"


def test_starting_a_class_ends_the_one_running(db: Database) -> None:
    first = start_class(db, WALL, "Anatomy A", "roster", "ann")
    second = start_class(db, WALL, "Anatomy B", "nickname", "ann")

    assert running_class(db, WALL) == second
    ended = get_class(db, first.id)
    assert ended is not None and not ended.running
    assert start_class(db, "other", "", "anonymous", "bob").running  # walls are apart
    assert running_class(db, WALL) == second


def test_a_class_without_a_title_is_named_by_its_start(db: Database) -> None:
    held = start_class(db, WALL, "  \u202e ", "anonymous", "ann")
    assert held.title == f"Class of {held.started_at:%Y-%m-%d %H:%M}"
    assert start_class(db, WALL, "x" * 500, "anonymous", "ann").title == "x" * 80


def test_an_untitled_class_is_named_by_its_start_in_the_walls_time_zone(db: Database) -> None:
    """Issue 41: the title said UTC, the dashboard's start time the wall's."""
    held = start_class(db, WALL, "", "anonymous", "ann", "America/Los_Angeles")
    local = held.started_at.astimezone(ZoneInfo("America/Los_Angeles"))
    assert held.title == f"Class of {local:%Y-%m-%d %H:%M}"


def test_ending_a_class_keeps_it_as_the_latest(db: Database) -> None:
    assert end_class(db, WALL, "ann") is None  # none ran
    held = start_class(db, WALL, "Anatomy", "anonymous", "ann")

    ended = end_class(db, WALL, "ann")

    assert ended is not None and ended.id == held.id and ended.ended_at is not None
    assert running_class(db, WALL) is None
    assert latest_class(db, WALL) == ended
    assert end_class(db, WALL, "ann") is None


def test_the_roll_counts_each_student_once_and_keeps_their_last_name(db: Database) -> None:
    held = start_class(db, WALL, "Anatomy", "roster", "ann")
    assert standing(db, WALL, "v1") is not None
    assert not standing(db, WALL, "v1").joined  # type: ignore[union-attr]

    join(db, held.id, "v1", "  A-0017 ")
    join(db, held.id, "v2", "B\u200b-0042\x00")
    join(db, held.id, "v1", "A-0018")

    assert joined_count(db, held.id) == 2
    assert roll_names(db, held.id) == {"v1": "A-0018", "v2": "B-0042"}
    now = standing(db, WALL, "v1")
    assert now is not None and now.joined and now.session.id == held.id
    assert standing(db, "other", "v1") is None  # no class runs there


@pytest.mark.parametrize(
    ("typed", "problem"),
    [("", "Please type your roster id."), (" \t ", "Please type your roster id.")],
)
def test_a_class_that_asks_a_name_refuses_none(db: Database, typed: str, problem: str) -> None:
    held = start_class(db, WALL, "Anatomy", "roster", "ann")
    with pytest.raises(ClassError, match=problem):
        join(db, held.id, "v1", typed)
    assert joined_count(db, held.id) == 0


def test_a_name_has_a_bounded_length(db: Database) -> None:
    held = start_class(db, WALL, "Anatomy", "nickname", "ann")
    with pytest.raises(ClassError, match=f"at most {MAX_NAME}"):
        join(db, held.id, "v1", "n" * (MAX_NAME + 1))
    join(db, held.id, "v1", "n" * MAX_NAME)
    assert roll_names(db, held.id) == {"v1": "n" * MAX_NAME}


def test_an_anonymous_class_keeps_no_name(db: Database) -> None:
    held = start_class(db, WALL, "Anatomy", "anonymous", "ann")
    join(db, held.id, "v1", "Mallory")
    assert roll_names(db, held.id) == {"v1": ""}


def test_nobody_joins_a_class_that_ended(db: Database) -> None:
    held = start_class(db, WALL, "Anatomy", "nickname", "ann")
    end_class(db, WALL, "ann")
    with pytest.raises(ClassError, match="ended"):
        join(db, held.id, "v1", "Ann")
    with pytest.raises(ClassError, match="ended"):
        join(db, 9_999, "v1", "Ann")
    assert joined_count(db, held.id) == 0


def test_the_class_at_a_moment_is_the_one_that_ran_then(db: Database) -> None:
    before = datetime.now(UTC) - timedelta(hours=1)
    first = start_class(db, WALL, "First", "anonymous", "ann")
    during_first = datetime.now(UTC)
    second = start_class(db, WALL, "Second", "anonymous", "ann")

    assert class_at(db, WALL, before) is None
    found = class_at(db, WALL, during_first)
    assert found is not None and found.id == first.id
    now = class_at(db, WALL, datetime.now(UTC))
    assert now is not None and now.id == second.id
