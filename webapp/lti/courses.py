"""Classes launched from a course: which course and link a class came from, its roster
(the platform's NRPS members and whoever launched), and its scores on their way to the
gradebook, kept until the platform accepts each one."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import select, update
from sqlalchemy.exc import IntegrityError

from webapp.classes.roll import ClassSession, join
from webapp.database.connection import Database, as_utc
from webapp.database.models import LtiClassRecord, LtiRosterRecord, LtiScoreRecord
from webapp.lti.messages import Member, Score
from webapp.people.person import plain_text
from webapp.quiz.engine import Quiz
from webapp.quiz.engine import Score as QuizScore

MAX_NAME = 80
MAX_PROBLEM = 300

# LIS role URIs (LTI 1.3 appendix A): whoever teaches the course runs its class; the
# context roles count, and the short forms some platforms send.
TEACHING_ROLES = frozenset(
    {
        "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor",
        "http://purl.imsglobal.org/vocab/lis/v2/membership#ContentDeveloper",
        "http://purl.imsglobal.org/vocab/lis/v2/membership#Administrator",
        "http://purl.imsglobal.org/vocab/lis/v2/membership/Instructor#TeachingAssistant",
        "Instructor",
        "ContentDeveloper",
        "Administrator",
        "TeachingAssistant",
    }
)


def teaches(roles: list[str]) -> bool:
    """Whether a person with these LTI roles runs the class (else they take part)."""
    return any(role in TEACHING_ROLES for role in roles)


def _name(text: str) -> str:
    return plain_text(text)[:MAX_NAME].strip()


@dataclass(frozen=True)
class CourseClass:
    """What a class launched from a course keeps of it."""

    class_id: int
    platform_id: int
    deployment_id: str
    context_id: str
    resource_link_id: str
    app: str
    lineitem_url: str | None
    memberships_url: str | None
    roster_problem: str


def _course_class(record: LtiClassRecord) -> CourseClass:
    return CourseClass(
        class_id=record.class_id,
        platform_id=record.platform_id,
        deployment_id=record.deployment_id,
        context_id=record.context_id,
        resource_link_id=record.resource_link_id,
        app=record.app,
        lineitem_url=record.lineitem_url,
        memberships_url=record.memberships_url,
        roster_problem=record.roster_problem,
    )


def link_class(db: Database, course: CourseClass) -> None:
    """Record that the class ``course.class_id`` was launched from this course's link."""
    with db.session() as session:
        session.merge(
            LtiClassRecord(
                class_id=course.class_id,
                platform_id=course.platform_id,
                deployment_id=course.deployment_id,
                context_id=course.context_id,
                resource_link_id=course.resource_link_id,
                app=course.app,
                lineitem_url=course.lineitem_url,
                memberships_url=course.memberships_url,
                roster_problem="",
            )
        )


def course_class(db: Database, class_id: int) -> CourseClass | None:
    with db.session() as session:
        record = session.get(LtiClassRecord, class_id)
        return _course_class(record) if record else None


def running_class_of_link(
    db: Database, platform_id: int, resource_link_id: str, running: ClassSession | None
) -> bool:
    """Whether ``running`` (a wall's running class) is the one this link launched."""
    if running is None:
        return False
    found = course_class(db, running.id)
    return (
        found is not None
        and found.platform_id == platform_id
        and found.resource_link_id == resource_link_id
    )


def save_roster(db: Database, class_id: int, members: list[Member]) -> None:
    """The course's members as the class's expected people (active ones only); those
    already on it keep the phone they joined with."""
    with db.session() as session:
        for member in members:
            if member.status != "Active":
                continue
            record = session.get(LtiRosterRecord, (class_id, member.user_id))
            if record is None:
                record = LtiRosterRecord(class_id=class_id, user_id=member.user_id)
                session.add(record)
            record.name = _name(member.full_name) or record.name
            record.learner = not teaches(member.roles)
        session.execute(
            update(LtiClassRecord)
            .where(LtiClassRecord.class_id == class_id)
            .values(roster_problem="")
        )


def roster_failed(db: Database, class_id: int, problem: str) -> None:
    with db.session() as session:
        session.execute(
            update(LtiClassRecord)
            .where(LtiClassRecord.class_id == class_id)
            .values(roster_problem=problem[:MAX_PROBLEM])
        )


def join_as(db: Database, class_id: int, visitor_id: str, user_id: str, name: str) -> str:
    """Put the phone of the course's person ``user_id`` on the class's roll under their
    course name (their own launch says who they are); returns the name."""
    kept = _name(name) or "Student"
    join(db, class_id, visitor_id, kept, named_by_course=True)
    with db.session() as session:
        record = session.get(LtiRosterRecord, (class_id, user_id))
        if record is None:
            record = LtiRosterRecord(class_id=class_id, user_id=user_id, learner=True)
            session.add(record)
        record.name = kept
        record.visitor_id = visitor_id
    return kept


@dataclass(frozen=True)
class Expected:
    name: str
    joined: bool


def roster(db: Database, class_id: int) -> list[Expected]:
    """The course's students for the class, by name, and whether each joined."""
    with db.reading() as connection:
        rows = connection.execute(
            select(LtiRosterRecord.name, LtiRosterRecord.visitor_id)
            .where(LtiRosterRecord.class_id == class_id, LtiRosterRecord.learner)
            .order_by(LtiRosterRecord.name)
        ).all()
    return [Expected(row.name, row.visitor_id is not None) for row in rows]


# --- scores to the gradebook ---------------------------------------------------------------


def queue_scores(db: Database, held: ClassSession, ended: datetime) -> int:
    """At End class: each student who joined gets their score queued for the line item
    (a student who did not join gets none); one queued already keeps it. Returns how many
    were queued."""
    course = course_class(db, held.id)
    if course is None or course.lineitem_url is None:
        return 0
    with db.reading() as connection:
        queued = set(
            connection.scalars(
                select(LtiScoreRecord.user_id).where(LtiScoreRecord.class_id == held.id)
            )
        )
        joined = {
            row.visitor_id: row.user_id
            for row in connection.execute(
                select(LtiRosterRecord.visitor_id, LtiRosterRecord.user_id).where(
                    LtiRosterRecord.class_id == held.id,
                    LtiRosterRecord.learner,
                    LtiRosterRecord.visitor_id.is_not(None),
                )
            )
            if row.user_id not in queued
        }
    scores = Quiz(db, course.app).scores(held.wall_id, held, joined)
    try:
        _add_scores(db, held, joined, scores, ended)
    except IntegrityError:  # queued at the same moment by another request: theirs stand
        return 0
    return len(scores)


def _add_scores(
    db: Database,
    held: ClassSession,
    joined: dict[str, str],
    scores: dict[str, QuizScore],
    ended: datetime,
) -> None:
    with db.session() as session:
        for visitor_id, score in scores.items():
            posted = Score(
                userId=joined[visitor_id],
                scoreGiven=score.right,
                scoreMaximum=score.asked,
                timestamp=ended,
                comment=f"{score.right} of {score.asked} answers right in {held.title}",
            )
            session.add(
                LtiScoreRecord(
                    class_id=held.id,
                    user_id=joined[visitor_id],
                    score=posted.model_dump(mode="json"),
                    next_try_at=ended,
                )
            )


@dataclass(frozen=True)
class Pending:
    id: int
    class_id: int
    score: Score
    attempts: int


def claim_due_scores(db: Database, lease_s: float, limit: int = 50) -> list[Pending]:
    """Scores not yet accepted whose next try is due, each claimed for ``lease_s``
    seconds by one conditional UPDATE: of several server processes, one posts it."""
    now = datetime.now(UTC)
    with db.reading() as connection:
        rows = connection.execute(
            select(
                LtiScoreRecord.id,
                LtiScoreRecord.class_id,
                LtiScoreRecord.score,
                LtiScoreRecord.attempts,
                LtiScoreRecord.next_try_at,
            )
            .where(LtiScoreRecord.posted_at.is_(None), LtiScoreRecord.next_try_at <= now)
            .order_by(LtiScoreRecord.next_try_at)
            .limit(limit)
        ).all()
    claimed = []
    with db.engine.begin() as connection:
        for row in rows:
            taken = connection.execute(
                update(LtiScoreRecord)
                .where(
                    LtiScoreRecord.id == row.id,
                    LtiScoreRecord.next_try_at == row.next_try_at,
                    LtiScoreRecord.posted_at.is_(None),
                )
                .values(next_try_at=now + timedelta(seconds=lease_s))
            ).rowcount
            if taken:
                score = Score.model_validate(row.score)
                claimed.append(Pending(row.id, row.class_id, score, row.attempts))
    return claimed


def score_posted(db: Database, score_id: int) -> None:
    with db.session() as session:
        session.execute(
            update(LtiScoreRecord)
            .where(LtiScoreRecord.id == score_id)
            .values(posted_at=datetime.now(UTC), problem="")
        )


def score_failed(
    db: Database, pending: Pending, problem: str, first_s: float, max_s: float
) -> datetime:
    """A failed post: tried again after a wait that doubles with each failure (from
    ``first_s`` up to ``max_s``); returns when."""
    wait = min(max_s, first_s * 2**pending.attempts)
    at = datetime.now(UTC) + timedelta(seconds=wait)
    with db.session() as session:
        session.execute(
            update(LtiScoreRecord)
            .where(LtiScoreRecord.id == pending.id)
            .values(attempts=pending.attempts + 1, problem=problem[:MAX_PROBLEM], next_try_at=at)
        )
    return at


@dataclass(frozen=True)
class Grades:
    """How a class's scores stand: sent and accepted, waiting for a try (with the last
    problem, and when the next try is)."""

    posted: int
    waiting: int
    problem: str
    next_try_at: datetime | None


def grades(db: Database, class_id: int) -> Grades:
    with db.reading() as connection:
        rows = connection.execute(
            select(
                LtiScoreRecord.posted_at, LtiScoreRecord.problem, LtiScoreRecord.next_try_at
            ).where(LtiScoreRecord.class_id == class_id)
        ).all()
    waiting = [r for r in rows if r.posted_at is None]
    problems = [r.problem for r in waiting if r.problem]
    return Grades(
        posted=len(rows) - len(waiting),
        waiting=len(waiting),
        problem=problems[0] if problems else "",
        next_try_at=min((as_utc(r.next_try_at) for r in waiting), default=None),
    )
