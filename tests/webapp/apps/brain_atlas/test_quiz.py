"""The quiz as stored: answers, finishing, rounds, statistics, CSV export."""

from __future__ import annotations

import csv
import io

import pytest

from webapp.apps.brain_atlas.content import Region
from webapp.apps.brain_atlas.quiz import (
    QuizError,
    close_round,
    export_csv,
    finish,
    get_round,
    new_order,
    open_round,
    progress,
    record_answer,
    set_reveal,
    start_round,
    statistics,
)
from webapp.database.connection import Database

WALL = "demo"
R = 1  # the round the tests answer in (opened by the fixture)


def region(region_id: str) -> Region:
    return Region(id=region_id, name=region_id.title(), hemisphere="left", labels=[1], sets=["k5"])


REGIONS = [region("alpha"), region("beta")]
ORDERS = {"k5": ["alpha", "beta"], "full": []}


@pytest.fixture(autouse=True)
def first_round(db: Database) -> None:
    assert open_round(db, WALL, "test", ORDERS).number == R


def test_an_answer_is_stored_and_can_be_changed_until_finishing(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "  Alpha   lobe ", False)
    record_answer(db, WALL, R, "v1", "k5", "alpha", "alpha", True)

    now = progress(db, WALL, R, "v1", "k5")

    assert now.answers["alpha"].text == "alpha"
    assert now.answers["alpha"].correct
    assert not now.finished
    assert not now.complete(REGIONS)


def test_finishing_needs_every_region_and_makes_answers_final(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "alpha", True)
    with pytest.raises(QuizError, match="1 pins still need an answer"):
        finish(db, WALL, R, "v1", "k5", REGIONS)

    record_answer(db, WALL, R, "v1", "k5", "beta", "gamma", False)
    done = finish(db, WALL, R, "v1", "k5", REGIONS)
    assert done.finished
    assert finish(db, WALL, R, "v1", "k5", REGIONS).finished  # finishing twice is harmless

    with pytest.raises(QuizError, match="final"):
        record_answer(db, WALL, R, "v1", "k5", "beta", "beta", True)
    assert progress(db, WALL, R, "v1", "k5").answers["beta"].text == "gamma"


@pytest.mark.parametrize("text", ["", "   ", "x" * 201])
def test_empty_or_overlong_answers_are_refused_and_nothing_is_stored(
    db: Database, text: str
) -> None:
    with pytest.raises(QuizError):
        record_answer(db, WALL, R, "v1", "k5", "alpha", text, False)
    assert progress(db, WALL, R, "v1", "k5").answers == {}


def test_answers_are_stored_as_plain_text(db: Database) -> None:
    """A NUL byte made PostgreSQL fail the request (a 500 for any student); control and
    format characters never reach the database, on either."""
    record_answer(db, WALL, R, "v1", "k5", "alpha", "tha\x00la\u200bmus\u202e", False)

    assert progress(db, WALL, R, "v1", "k5").answers["alpha"].text == "thalamus"


def test_sets_visitors_and_walls_are_separate(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "alpha", True)

    assert progress(db, WALL, R, "v1", "full").answers == {}
    assert progress(db, WALL, R, "v2", "k5").answers == {}
    assert progress(db, "other", R, "v1", "k5").answers == {}


def test_a_new_round_closes_the_last_and_keeps_its_answers(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "alpha", True)
    record_answer(db, WALL, R, "v1", "k5", "beta", "beta", True)
    finish(db, WALL, R, "v1", "k5", REGIONS)

    second = start_round(db, WALL, "login:ann", {"k5": ["beta", "alpha"]})

    assert second.number == 2 and second.open and second.reveal == "close"
    first = get_round(db, WALL, R)
    assert first is not None and not first.open
    assert second.pins("k5", REGIONS) == {1: REGIONS[1], 2: REGIONS[0]}
    assert progress(db, WALL, 2, "v1", "k5") == progress(db, WALL, 2, "nobody", "k5")
    record_answer(db, WALL, 2, "v1", "k5", "alpha", "again", False)
    first_rows = list(csv.DictReader(io.StringIO(export_csv(db, WALL, 1))))
    assert [row["answer"] for row in first_rows] == ["alpha", "beta"]
    second_rows = list(csv.DictReader(io.StringIO(export_csv(db, WALL, 2))))
    assert [(row["round"], row["answer"]) for row in second_rows] == [("2", "again")]
    assert open_round(db, WALL, "app", ORDERS).number == 2  # the open one is kept


def test_a_closed_round_takes_no_answer_and_no_finishing(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "alpha", True)
    record_answer(db, WALL, R, "v2", "k5", "alpha", "alpha", True)
    record_answer(db, WALL, R, "v2", "k5", "beta", "x", False)

    closed = close_round(db, WALL, R, "login:ann")

    assert not closed.open and closed.names_shown(finished=False)
    with pytest.raises(QuizError, match="closed"):
        record_answer(db, WALL, R, "v1", "k5", "beta", "beta", True)
    with pytest.raises(QuizError, match="closed"):
        finish(db, WALL, R, "v2", "k5", REGIONS)
    with pytest.raises(QuizError, match="closed"):
        set_reveal(db, WALL, R, "finish")
    assert "beta" not in progress(db, WALL, R, "v1", "k5").answers


def test_names_show_at_closing_or_at_finishing_where_the_round_says_so(db: Database) -> None:
    quiz_round = get_round(db, WALL, R)
    assert quiz_round is not None
    assert not quiz_round.names_shown(finished=False)
    assert not quiz_round.names_shown(finished=True)  # default: only when closed

    at_finishing = set_reveal(db, WALL, R, "finish")

    assert not at_finishing.names_shown(finished=False)
    assert at_finishing.names_shown(finished=True)


def test_each_order_is_a_fresh_permutation_of_the_set() -> None:
    regions = [region(f"r{i}") for i in range(23)]
    orders = {tuple(new_order(regions)) for _ in range(20)}
    assert all(sorted(order) == sorted(r.id for r in regions) for order in orders)
    assert len(orders) == 20  # 20 draws of 23! orders: a repeat has chance ~1e-20


def test_pin_numbers_survive_content_changes_mid_round(db: Database) -> None:
    quiz_round = start_round(db, WALL, "t", {"k5": ["beta", "gone", "alpha"]})
    gamma = region("gamma")

    pins = quiz_round.pins("k5", [*REGIONS, gamma])

    assert pins == {1: REGIONS[1], 3: REGIONS[0], 4: gamma}


def test_statistics_count_share_correct_and_common_wrong_answers(db: Database) -> None:
    for visitor, text, correct in [
        ("v1", "alpha", True),
        ("v2", "Gamma", False),
        ("v3", "gamma", False),
        ("v4", "delta", False),
    ]:
        record_answer(db, WALL, R, visitor, "k5", "alpha", text, correct)
    record_answer(db, WALL, R, "v1", "k5", "beta", "beta", True)
    finish(db, WALL, R, "v1", "k5", REGIONS)

    stats = statistics(db, WALL, R, "k5", REGIONS)

    assert (stats.participants, stats.finished) == (4, 1)
    alpha, beta = stats.regions
    assert (alpha.answered, alpha.correct, alpha.share_correct) == (4, 1, 0.25)
    assert alpha.common_wrong == [("gamma", 2), ("delta", 1)]
    assert (beta.answered, beta.share_correct, beta.common_wrong) == (1, 1.0, [])
    assert statistics(db, WALL, R, "full", REGIONS).participants == 0


def test_the_export_defuses_answers_that_look_like_formulas(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "=HYPERLINK(1)", False)

    rows = list(csv.reader(io.StringIO(export_csv(db, WALL, R))))

    assert rows[0] == [
        "round",
        "visitor",
        "name",
        "tag_set",
        "region",
        "answer",
        "correct",
        "answered_at",
        "class",
    ]
    assert rows[1][5] == "'=HYPERLINK(1)"
    assert rows[1][6] == "no"


def test_the_export_tells_times_in_the_walls_zone(db: Database) -> None:
    record_answer(db, WALL, R, "v1", "k5", "alpha", "Alpha", True)
    [row] = csv.DictReader(io.StringIO(export_csv(db, WALL, R, "Asia/Kolkata")))
    assert row["answered_at"].endswith("+05:30")
    [row] = csv.DictReader(io.StringIO(export_csv(db, WALL, R)))
    assert row["answered_at"].endswith("+00:00")
