"""The quiz as stored: answers, finishing, rounds, statistics, CSV export."""

from __future__ import annotations

import csv
import io

import pytest

from webapp.apps.brain_atlas.content import Region
from webapp.apps.brain_atlas.quiz import (
    QuizError,
    current_round,
    export_csv,
    finish,
    progress,
    record_answer,
    start_round,
    statistics,
)
from webapp.db import Database

WALL = "demo"


def region(region_id: str) -> Region:
    return Region(id=region_id, name=region_id.title(), hemisphere="left", labels=[1], sets=["k5"])


REGIONS = [region("alpha"), region("beta")]


def test_an_answer_is_stored_and_can_be_changed_until_finishing(db: Database) -> None:
    record_answer(db, WALL, "v1", "k5", "alpha", "  Alpha   lobe ", False)
    record_answer(db, WALL, "v1", "k5", "alpha", "alpha", True)

    now = progress(db, WALL, "v1", "k5")

    assert now.answers["alpha"].text == "alpha"
    assert now.answers["alpha"].correct
    assert not now.finished
    assert not now.complete(REGIONS)


def test_finishing_needs_every_region_and_makes_answers_final(db: Database) -> None:
    record_answer(db, WALL, "v1", "k5", "alpha", "alpha", True)
    with pytest.raises(QuizError, match="1 pins still need an answer"):
        finish(db, WALL, "v1", "k5", REGIONS)

    record_answer(db, WALL, "v1", "k5", "beta", "gamma", False)
    done = finish(db, WALL, "v1", "k5", REGIONS)
    assert done.finished
    assert finish(db, WALL, "v1", "k5", REGIONS).finished  # finishing twice is harmless

    with pytest.raises(QuizError, match="final"):
        record_answer(db, WALL, "v1", "k5", "beta", "beta", True)
    assert progress(db, WALL, "v1", "k5").answers["beta"].text == "gamma"


@pytest.mark.parametrize("text", ["", "   ", "x" * 201])
def test_empty_or_overlong_answers_are_refused_and_nothing_is_stored(
    db: Database, text: str
) -> None:
    with pytest.raises(QuizError):
        record_answer(db, WALL, "v1", "k5", "alpha", text, False)
    assert progress(db, WALL, "v1", "k5").answers == {}


def test_sets_visitors_and_walls_are_separate(db: Database) -> None:
    record_answer(db, WALL, "v1", "k5", "alpha", "alpha", True)

    assert progress(db, WALL, "v1", "full").answers == {}
    assert progress(db, WALL, "v2", "k5").answers == {}
    assert progress(db, "other", "v1", "k5").answers == {}


def test_a_reset_starts_a_new_round_and_keeps_the_old_one(db: Database) -> None:
    assert current_round(db, WALL) == 1
    record_answer(db, WALL, "v1", "k5", "alpha", "alpha", True)
    record_answer(db, WALL, "v1", "k5", "beta", "beta", True)
    finish(db, WALL, "v1", "k5", REGIONS)

    assert start_round(db, WALL, "login:ann") == 2

    assert progress(db, WALL, "v1", "k5") == progress(db, WALL, "nobody", "k5")
    record_answer(db, WALL, "v1", "k5", "alpha", "again", False)
    first = list(csv.DictReader(io.StringIO(export_csv(db, WALL, 1))))
    assert [row["answer"] for row in first] == ["alpha", "beta"]
    second = list(csv.DictReader(io.StringIO(export_csv(db, WALL))))
    assert [(row["round"], row["answer"]) for row in second] == [("2", "again")]


def test_statistics_count_share_correct_and_common_wrong_answers(db: Database) -> None:
    for visitor, text, correct in [
        ("v1", "alpha", True),
        ("v2", "Gamma", False),
        ("v3", "gamma", False),
        ("v4", "delta", False),
    ]:
        record_answer(db, WALL, visitor, "k5", "alpha", text, correct)
    record_answer(db, WALL, "v1", "k5", "beta", "beta", True)
    finish(db, WALL, "v1", "k5", REGIONS)

    stats = statistics(db, WALL, "k5", REGIONS)

    assert (stats.participants, stats.finished) == (4, 1)
    alpha, beta = stats.regions
    assert (alpha.answered, alpha.correct, alpha.share_correct) == (4, 1, 0.25)
    assert alpha.common_wrong == [("gamma", 2), ("delta", 1)]
    assert (beta.answered, beta.share_correct, beta.common_wrong) == (1, 1.0, [])
    assert statistics(db, WALL, "full", REGIONS).participants == 0


def test_the_export_defuses_answers_that_look_like_formulas(db: Database) -> None:
    record_answer(db, WALL, "v1", "k5", "alpha", "=HYPERLINK(1)", False)

    rows = list(csv.reader(io.StringIO(export_csv(db, WALL))))

    assert rows[0] == [
        "round",
        "visitor",
        "name",
        "tag_set",
        "region",
        "answer",
        "correct",
        "answered_at",
    ]
    assert rows[1][5] == "'=HYPERLINK(1)"
    assert rows[1][6] == "no"
