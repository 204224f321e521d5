"""The shared quiz engine as stored: answers, finishing, rounds, statistics, CSV export."""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from typing import Any

import pytest
from sqlalchemy import event

from webapp.classes.roll import end_class, start_class
from webapp.database.connection import Database
from webapp.quiz.engine import Columns, Question, Quiz, QuizError, Score, new_order

WALL = "demo"
R = 1  # the round the tests answer in (opened by the fixture)


APP = "brain"
BRAIN_COLUMNS = Columns(set="tag_set", item="region")


@dataclass(frozen=True)
class Item:
    """What a quiz numbers (the brain's regions, an image's hotspots)."""

    id: str


def quiz(db: Database) -> Quiz:
    return Quiz(db, APP, BRAIN_COLUMNS)


def region(item_id: str) -> Item:
    return Item(item_id)


def typed(item_id: str) -> Question:
    """A question answered in free text, judged by its app (as the brain's pins)."""
    return Question(item_id, "What is the name of this region?")


ALPHA, BETA = typed("alpha"), typed("beta")
REGIONS = [region("alpha"), region("beta")]
ORDERS = {"k5": ["alpha", "beta"], "full": []}


@pytest.fixture(autouse=True)
def first_round(db: Database) -> None:
    assert quiz(db).open_round(WALL, "test", ORDERS).number == R


def test_an_answer_is_stored_and_can_be_changed_until_finishing(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "  Alpha   lobe ", False)
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)

    now = quiz(db).progress(WALL, R, "v1", "k5")

    assert now.answers["alpha"].text == "alpha"
    assert now.answers["alpha"].correct
    assert not now.finished
    assert not now.complete(REGIONS)


def test_finishing_needs_every_region_and_makes_answers_final(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)
    with pytest.raises(QuizError, match="1 question still needs an answer"):
        quiz(db).finish(WALL, R, "v1", "k5", REGIONS)

    quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "gamma", False)
    done = quiz(db).finish(WALL, R, "v1", "k5", REGIONS)
    assert done.finished
    assert quiz(db).finish(WALL, R, "v1", "k5", REGIONS).finished  # finishing twice is harmless

    with pytest.raises(QuizError, match="final"):
        quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "beta", True)
    assert quiz(db).progress(WALL, R, "v1", "k5").answers["beta"].text == "gamma"


@pytest.mark.parametrize("text", ["", "   ", "x" * 201])
def test_empty_or_overlong_answers_are_refused_and_nothing_is_stored(
    db: Database, text: str
) -> None:
    with pytest.raises(QuizError):
        quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, text, False)
    assert quiz(db).progress(WALL, R, "v1", "k5").answers == {}


def test_answers_are_stored_as_plain_text(db: Database) -> None:
    """A NUL byte made PostgreSQL fail the request (a 500 for any student); control and
    format characters never reach the database, on either."""
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "tha\x00la\u200bmus\u202e", False)

    assert quiz(db).progress(WALL, R, "v1", "k5").answers["alpha"].text == "thalamus"


def test_sets_visitors_and_walls_are_separate(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)

    assert quiz(db).progress(WALL, R, "v1", "full").answers == {}
    assert quiz(db).progress(WALL, R, "v2", "k5").answers == {}
    assert quiz(db).progress("other", R, "v1", "k5").answers == {}


def test_a_new_round_closes_the_last_and_keeps_its_answers(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)
    quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "beta", True)
    quiz(db).finish(WALL, R, "v1", "k5", REGIONS)

    second = quiz(db).start_round(WALL, "login:ann", {"k5": ["beta", "alpha"]})

    assert second.number == 2 and second.open and second.reveal == "close"
    first = quiz(db).get_round(WALL, R)
    assert first is not None and not first.open
    assert second.numbered("k5", REGIONS) == {1: REGIONS[1], 2: REGIONS[0]}
    assert quiz(db).progress(WALL, 2, "v1", "k5") == quiz(db).progress(WALL, 2, "nobody", "k5")
    quiz(db).record_answer(WALL, 2, "v1", "k5", ALPHA, "again", False)
    first_rows = list(csv.DictReader(io.StringIO(quiz(db).export_csv(WALL, 1))))
    assert [row["answer"] for row in first_rows] == ["alpha", "beta"]
    second_rows = list(csv.DictReader(io.StringIO(quiz(db).export_csv(WALL, 2))))
    assert [(row["round"], row["answer"]) for row in second_rows] == [("2", "again")]
    assert quiz(db).open_round(WALL, "app", ORDERS).number == 2  # the open one is kept


def test_a_closed_round_takes_no_answer_and_no_finishing(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)
    quiz(db).record_answer(WALL, R, "v2", "k5", ALPHA, "alpha", True)
    quiz(db).record_answer(WALL, R, "v2", "k5", BETA, "x", False)

    closed = quiz(db).close_round(WALL, R, "login:ann")

    assert not closed.open and closed.names_shown(finished=False)
    with pytest.raises(QuizError, match="closed"):
        quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "beta", True)
    with pytest.raises(QuizError, match="closed"):
        quiz(db).finish(WALL, R, "v2", "k5", REGIONS)
    with pytest.raises(QuizError, match="closed"):
        quiz(db).set_reveal(WALL, R, "finish")
    assert "beta" not in quiz(db).progress(WALL, R, "v1", "k5").answers


def test_names_show_at_closing_or_at_finishing_where_the_round_says_so(db: Database) -> None:
    quiz_round = quiz(db).get_round(WALL, R)
    assert quiz_round is not None
    assert not quiz_round.names_shown(finished=False)
    assert not quiz_round.names_shown(finished=True)  # default: only when closed

    at_finishing = quiz(db).set_reveal(WALL, R, "finish")

    assert not at_finishing.names_shown(finished=False)
    assert at_finishing.names_shown(finished=True)


def test_each_order_is_a_fresh_permutation_of_the_set() -> None:
    regions = [region(f"r{i}") for i in range(23)]
    orders = {tuple(new_order(regions)) for _ in range(20)}
    assert all(sorted(order) == sorted(r.id for r in regions) for order in orders)
    assert len(orders) == 20  # 20 draws of 23! orders: a repeat has chance ~1e-20


def test_pin_numbers_survive_content_changes_mid_round(db: Database) -> None:
    quiz_round = quiz(db).start_round(WALL, "t", {"k5": ["beta", "gone", "alpha"]})
    gamma = region("gamma")

    pins = quiz_round.numbered("k5", [*REGIONS, gamma])

    assert pins == {1: REGIONS[1], 3: REGIONS[0], 4: gamma}


def test_statistics_count_share_correct_and_common_wrong_answers(db: Database) -> None:
    for visitor, text, correct in [
        ("v1", "alpha", True),
        ("v2", "Gamma", False),
        ("v3", "gamma", False),
        ("v4", "delta", False),
    ]:
        quiz(db).record_answer(WALL, R, visitor, "k5", ALPHA, text, correct)
    quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "beta", True)
    quiz(db).finish(WALL, R, "v1", "k5", REGIONS)

    stats = quiz(db).statistics(WALL, R, "k5", [ALPHA, BETA])

    assert (stats.participants, stats.finished) == (4, 1)
    alpha, beta = stats.items
    assert (alpha.answered, alpha.correct, alpha.share_correct) == (4, 1, 0.25)
    assert alpha.common_wrong == [("gamma", 2), ("delta", 1)]
    assert (beta.answered, beta.share_correct, beta.common_wrong) == (1, 1.0, [])
    assert quiz(db).statistics(WALL, R, "full", [ALPHA, BETA]).participants == 0


def test_the_export_defuses_answers_that_look_like_formulas(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "=HYPERLINK(1)", False)

    rows = list(csv.reader(io.StringIO(quiz(db).export_csv(WALL, R))))

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
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "Alpha", True)
    [row] = csv.DictReader(io.StringIO(quiz(db).export_csv(WALL, R, "Asia/Kolkata")))
    assert row["answered_at"].endswith("+05:30")
    [row] = csv.DictReader(io.StringIO(quiz(db).export_csv(WALL, R)))
    assert row["answered_at"].endswith("+00:00")


def test_each_app_keeps_its_own_rounds_and_answers(db: Database) -> None:
    image = Quiz(db, "image")
    opened = image.open_round(WALL, "test", {"hotspots": ["h1"]})
    assert opened.number == 1  # numbered per app: the brain's round 1 is another
    image.record_answer(WALL, 1, "v1", "hotspots", typed("h1"), "Mona Lisa", True)

    assert quiz(db).progress(WALL, R, "v1", "hotspots").answers == {}
    assert image.progress(WALL, 1, "v1", "hotspots").answers["h1"].text == "Mona Lisa"
    image.close_round(WALL, 1, "ann")
    brain_round = quiz(db).get_round(WALL, R)
    assert brain_round is not None and brain_round.open
    assert "Mona Lisa" not in quiz(db).export_csv(WALL, R)


def test_an_answer_is_one_transaction_that_reads_nothing_back(db: Database) -> None:
    """A room's answers hold the write lock in turn: each is the round claimed, the
    finish checked and the answer written, and no more (the progress page reads)."""
    statements: list[str] = []

    def executed(_conn: Any, _cursor: Any, statement: str, *_: Any) -> None:
        statements.append(statement.split()[0].upper())

    event.listen(db.engine, "before_cursor_execute", executed)
    try:
        quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)
        first = list(statements)
        statements.clear()
        quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "beta", False)
    finally:
        event.remove(db.engine, "before_cursor_execute", executed)
    assert first == ["UPDATE", "SELECT", "UPDATE", "INSERT"]  # a new answer
    assert statements == ["UPDATE", "SELECT", "UPDATE"]  # a changed one
    assert quiz(db).progress(WALL, R, "v1", "k5").answers["alpha"].text == "beta"


# --- questions with choices, polls, answers given once --------------------------------

COLOUR = Question(
    "colour", "Which colour is the nucleus?", ("blue", "red", "green"), frozenset({"blue"})
)
PACE = Question("pace", "How was the pace?", ("too slow", "right", "too fast"))  # a poll


def test_the_engine_judges_a_choice_and_refuses_one_not_offered(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", COLOUR, " blue ")
    quiz(db).record_answer(WALL, R, "v2", "k5", COLOUR, "red")

    assert quiz(db).progress(WALL, R, "v1", "k5").answers["colour"].correct is True
    assert quiz(db).progress(WALL, R, "v2", "k5").answers["colour"].correct is False
    for offered_not in ("purple", "Blue", "", "blue; red"):
        with pytest.raises(QuizError, match="choose one of the answers offered"):
            quiz(db).record_answer(WALL, R, "v3", "k5", COLOUR, offered_not)
    with pytest.raises(QuizError, match="choose one"):
        quiz(db).answer_once(WALL, R, "v3", "k5", PACE, "too quick")
    assert quiz(db).progress(WALL, R, "v3", "k5").answers == {}


def test_a_choice_is_judged_by_the_engine_not_the_app(db: Database) -> None:
    with pytest.raises(ValueError, match="the quiz judges"):
        quiz(db).record_answer(WALL, R, "v1", "k5", COLOUR, "red", True)
    assert quiz(db).progress(WALL, R, "v1", "k5").answers == {}


@pytest.mark.parametrize(
    ("fields", "problem"),
    [
        ({"id": ""}, "id has 1 to 64"),
        ({"id": "x" * 65}, "id has 1 to 64"),
        ({"choices": ("a", "a")}, "a choice twice"),
        ({"choices": ("a", " b")}, "not a plain choice"),
        ({"choices": ("a", "")}, "not a plain choice"),
        ({"choices": ("a", "b"), "right": frozenset({"c"})}, "among its choices"),
        ({"right": frozenset({"a"})}, "among its choices"),  # typed text: its app judges
    ],
)
def test_a_question_no_answer_could_be_judged_against_is_refused(
    fields: dict[str, Any], problem: str
) -> None:
    with pytest.raises(ValueError, match=problem):
        Question(**{"id": "q", "text": "Which?", **fields})


def test_a_poll_is_neither_right_nor_wrong_and_counted_per_choice(db: Database) -> None:
    for visitor, choice in [("v1", "right"), ("v2", "too fast"), ("v3", "right")]:
        quiz(db).answer_once(WALL, R, visitor, "poll", PACE, choice)
    quiz(db).record_answer(WALL, R, "v4", "poll", typed("word"), "Neurons")  # free text

    stats = quiz(db).statistics(WALL, R, "poll", [PACE, typed("word")])

    pace, word = stats.items
    assert pace.choices == {"too slow": 0, "right": 2, "too fast": 1}
    assert list(pace.choices) == list(PACE.choices)  # in the question's order
    assert (pace.answered, pace.judged, pace.share_correct, pace.common_wrong) == (3, 0, None, [])
    assert (word.answered, word.share_correct, word.choices) == (1, None, {})
    assert quiz(db).progress(WALL, R, "v1", "poll").answers["pace"].correct is None
    rows = list(csv.DictReader(io.StringIO(quiz(db).export_csv(WALL, R))))
    assert {row["correct"] for row in rows} == {"n/a"}


def test_a_judged_share_leaves_unjudged_answers_out(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", COLOUR, "blue")
    quiz(db).record_answer(WALL, R, "v2", "k5", COLOUR, "green")

    [colour] = quiz(db).statistics(WALL, R, "k5", [COLOUR]).items

    assert (colour.judged, colour.correct, colour.share_correct) == (2, 1, 0.5)
    assert colour.choices == {"blue": 1, "red": 0, "green": 1}
    assert colour.common_wrong == [("green", 1)]


def test_an_answer_given_once_is_final_at_once(db: Database) -> None:
    quiz(db).answer_once(WALL, R, "v1", "poll", PACE, "right")

    with pytest.raises(QuizError, match="answered this question already"):
        quiz(db).answer_once(WALL, R, "v1", "poll", PACE, "too fast")
    with pytest.raises(QuizError, match="your answer is final"):
        quiz(db).record_answer(WALL, R, "v1", "poll", PACE, "too fast")
    assert quiz(db).progress(WALL, R, "v1", "poll").answers["pace"].text == "right"
    assert not quiz(db).progress(WALL, R, "v1", "poll").finished  # nothing to finish
    quiz(db).answer_once(WALL, R, "v2", "poll", PACE, "too fast")  # others still answer


def test_an_answer_given_once_after_one_to_change_is_refused(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "poll", PACE, "right")
    with pytest.raises(QuizError, match="already"):
        quiz(db).answer_once(WALL, R, "v1", "poll", PACE, "too fast")
    assert quiz(db).progress(WALL, R, "v1", "poll").answers["pace"].text == "right"


def test_a_closed_or_finished_round_takes_no_answer_given_once(db: Database) -> None:
    quiz(db).record_answer(WALL, R, "v1", "k5", ALPHA, "alpha", True)
    quiz(db).record_answer(WALL, R, "v1", "k5", BETA, "beta", True)
    quiz(db).finish(WALL, R, "v1", "k5", REGIONS)
    with pytest.raises(QuizError, match="finished"):
        quiz(db).answer_once(WALL, R, "v1", "k5", COLOUR, "blue")

    quiz(db).close_round(WALL, R, "ann")

    with pytest.raises(QuizError, match="closed"):
        quiz(db).answer_once(WALL, R, "v2", "poll", PACE, "right")
    assert quiz(db).progress(WALL, R, "v2", "poll").answers == {}


def test_an_answer_given_once_is_one_transaction(db: Database) -> None:
    """The round claimed, the finish checked, the answer written: no update to try."""
    statements: list[str] = []

    def executed(_conn: Any, _cursor: Any, statement: str, *_: Any) -> None:
        statements.append(statement.split()[0].upper())

    event.listen(db.engine, "before_cursor_execute", executed)
    try:
        quiz(db).answer_once(WALL, R, "v1", "poll", PACE, "right")
    finally:
        event.remove(db.engine, "before_cursor_execute", executed)
    assert statements == ["UPDATE", "SELECT", "INSERT"]


# --- the app's CSV columns -------------------------------------------------------------


def test_the_export_names_its_columns_as_the_app_says_and_describes_each_item(
    db: Database,
) -> None:
    spots = Quiz(db, "image", Columns(set="image", item="hotspot", about=("title", "question")))
    spots.open_round(WALL, "test", {"img": ["h1", "h2"]})
    spots.record_answer(WALL, 1, "v1", "img", typed("h1"), "Nucleus", True)
    spots.record_answer(WALL, 1, "v1", "img", typed("h2"), "Wall", False)
    about = {("img", "h1"): ("=Nucleus", "What is this part called?")}  # h2 was removed

    rows = list(csv.reader(io.StringIO(spots.export_csv(WALL, 1, about=about))))

    assert rows[0] == [
        "round",
        "visitor",
        "name",
        "image",
        "hotspot",
        "title",
        "question",
        "answer",
        "correct",
        "answered_at",
        "class",
    ]
    assert rows[1][3:9] == ["img", "h1", "'=Nucleus", "What is this part called?", "Nucleus", "yes"]
    assert rows[2][3:9] == ["img", "h2", "", "", "Wall", "no"]
    with pytest.raises(ValueError, match="described in 2 columns"):
        spots.export_csv(WALL, 1, about={("img", "h1"): ("Nucleus",)})


def test_an_app_that_names_no_columns_gets_set_and_item() -> None:
    assert Columns().header()[3:5] == ["set", "item"]
    with pytest.raises(ValueError, match="each column once"):
        Columns(set="poll", item="question", about=("answer",))


def test_a_students_score_is_right_answers_of_the_questions_asked(db: Database) -> None:
    """The one rule of a grade (a class from a course posts it): over the class's
    rounds, the answers judged right against the questions of the set each answered
    (the largest set where they answered nothing); only the students named count."""
    quiz(db).close_round(WALL, R, "test")  # before the class: not the class's round
    held = start_class(db, WALL, "Bio", "anonymous", "test")
    number = quiz(db).open_round(WALL, "test", {"k5": ["alpha", "beta"], "full": ["alpha"]})
    quiz(db).record_answer(WALL, number.number, "v1", "k5", ALPHA, "alpha", True)
    quiz(db).record_answer(WALL, number.number, "v1", "k5", BETA, "x", False)
    quiz(db).record_answer(WALL, number.number, "v2", "full", ALPHA, "alpha", True)
    ended = end_class(db, WALL, "test")
    assert ended is not None
    scores = quiz(db).scores(WALL, ended, ["v1", "v2", "v3"])
    assert scores == {
        "v1": Score(right=1, asked=2),
        "v2": Score(right=1, asked=1),
        "v3": Score(right=0, asked=2),  # joined, answered nothing: the largest set
    }
    assert held.id == ended.id
