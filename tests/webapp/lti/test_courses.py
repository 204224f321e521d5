"""A class launched from a course: its roster and roles, the scores queued when it ends
(by End class or by the next class's start), and their tries."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

from fastapi.testclient import TestClient
from sqlalchemy import select, update

from tests.conftest import operator_headers, services_of
from webapp.classes.roll import end_class, get_class, start_class
from webapp.database.connection import Database
from webapp.database.models import LtiScoreRecord
from webapp.lti.courses import (
    CourseClass,
    Pending,
    claim_due_scores,
    grades,
    join_as,
    link_class,
    queue_scores,
    roster,
    save_roster,
    score_failed,
    teaches,
)
from webapp.lti.messages import Member
from webapp.lti.platforms import add_platform
from webapp.quiz.engine import Question, Quiz

LEARNER = "http://purl.imsglobal.org/vocab/lis/v2/membership#Learner"
INSTRUCTOR = "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor"
UNREACHABLE = "http://127.0.0.1:9"  # nothing listens: every post fails at once


def course_with_students(db: Database) -> int:
    """A course's class at the demo wall, Ada and Sam joined, Ben on the roster only;
    a brain round in which Ada answered one of two questions right."""
    platform = add_platform(
        db,
        name="LMS",
        issuer=UNREACHABLE,
        client_id="c",
        deployment_ids=["d"],
        auth_url=f"{UNREACHABLE}/auth",
        token_url=f"{UNREACHABLE}/token",
        jwks_url=f"{UNREACHABLE}/jwks",
        actor="test",
    )
    held = start_class(db, "demo", "Biology 101", "course", "test")
    link_class(
        db,
        CourseClass(
            class_id=held.id,
            platform_id=platform.id,
            deployment_id="d",
            context_id="bio101",
            resource_link_id="link-1",
            app="brain",
            lineitem_url=f"{UNREACHABLE}/lineitems/1",
            memberships_url=None,
            roster_problem="",
        ),
    )
    save_roster(
        db,
        held.id,
        [
            Member(user_id="ines", roles=[INSTRUCTOR], name="Ines Teacher"),
            Member(user_id="ada", roles=[LEARNER], name="Ada Lovelace"),
            Member(user_id="sam", roles=[LEARNER], given_name="Sam", family_name="Student"),
            Member(user_id="ben", roles=[LEARNER], name="Ben Absent"),
            Member(user_id="gone", roles=[LEARNER], name="Gone", status="Inactive"),
        ],
    )
    assert join_as(db, held.id, "phone-ada", "ada", "Ada  Lovelace\u202e") == "Ada Lovelace"
    join_as(db, held.id, "phone-sam", "sam", "Sam Student")
    quiz = Quiz(db, "brain")
    number = quiz.open_round("demo", "test", {"k5": ["alpha", "beta"]}).number
    quiz.record_answer("demo", number, "phone-ada", "k5", Question("alpha", "?"), "a", True)
    quiz.record_answer("demo", number, "phone-ada", "k5", Question("beta", "?"), "b", False)
    return held.id


def test_the_roster_names_who_joined_and_who_is_missing(db: Database) -> None:
    class_id = course_with_students(db)
    assert [(p.name, p.joined) for p in roster(db, class_id)] == [
        ("Ada Lovelace", True),
        ("Ben Absent", False),
        ("Sam Student", True),
    ]  # the instructor is no student; an inactive member is not expected
    assert teaches([INSTRUCTOR]) and teaches(["TeachingAssistant"]) and not teaches([LEARNER])


def test_a_class_ended_by_the_next_start_sends_its_grades(client: TestClient) -> None:
    db = services_of(client).db
    class_id = course_with_students(db)
    started = client.post(
        "/api/walls/demo/class", json={"app": "pattern"}, headers=operator_headers(client)
    )
    assert started.status_code == 200, started.text
    with db.session() as session:
        queued = {r.user_id: r.score for r in session.scalars(select(LtiScoreRecord))}
    assert set(queued) == {"ada", "sam"}  # Ben never joined: none
    assert (queued["ada"]["scoreGiven"], queued["ada"]["scoreMaximum"]) == (1, 2)
    assert (queued["sam"]["scoreGiven"], queued["sam"]["scoreMaximum"]) == (0, 2)
    assert queued["ada"]["activityProgress"] == "Completed"
    assert queued["ada"]["gradingProgress"] == "FullyGraded"
    assert started.json()["id"] != class_id
    ended = get_class(db, class_id)
    assert ended is not None and ended.ended_at is not None
    assert queue_scores(db, ended, datetime.now(UTC)) == 0  # queued once


def test_a_score_is_claimed_by_one_poster_and_waits_longer_after_each_failure(
    db: Database,
) -> None:
    class_id = course_with_students(db)
    ended = end_class(db, "demo", "test")
    assert ended is not None and ended.ended_at is not None
    assert queue_scores(db, ended, ended.ended_at) == 2
    claimed = claim_due_scores(db, lease_s=60)
    assert len(claimed) == 2
    assert claim_due_scores(db, lease_s=60) == []  # another process finds them taken
    before = datetime.now(UTC)
    first = score_failed(db, claimed[0], "503 gradebook unavailable", 30, 3600)
    assert timedelta(seconds=29) < first - before < timedelta(seconds=31)
    again = Pending(claimed[0].id, class_id, claimed[0].score, attempts=5)
    later = score_failed(db, again, "503", 30, 3600)
    assert later - before > timedelta(minutes=15)  # 30 s x 2^5
    standing = grades(db, class_id)
    assert (standing.posted, standing.waiting, standing.problem) == (0, 2, "503")
    with db.session() as session:  # the waits are over: both due again
        session.execute(update(LtiScoreRecord).values(next_try_at=before))
    assert len(claim_due_scores(db, lease_s=60)) == 2
