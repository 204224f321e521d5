"""Database tables (SQLAlchemy 2 typed models); wire schemas live in pydantic models."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import (
    JSON,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    String,
    Text,
    UniqueConstraint,
    text,
)
from sqlalchemy.orm import Mapped, mapped_column

from webapp.database.connection import Base


def _utcnow() -> datetime:
    return datetime.now(UTC)


class WallStateRecord(Base):
    """The current state of one wall and its version (bumped by one per change)."""

    __tablename__ = "wall_states"

    wall_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    version: Mapped[int] = mapped_column(Integer, nullable=False)
    state: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    updated_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, onupdate=_utcnow, nullable=False
    )


class WallEventRecord(Base):
    """One committed change, kept so a reconnecting tile can replay what it missed."""

    __tablename__ = "wall_events"

    wall_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    version: Mapped[int] = mapped_column(Integer, primary_key=True)
    changes: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    heavy: Mapped[bool] = mapped_column(nullable=False, default=False)
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class TagRecord(Base):
    """A registered code: what it does, what it carries and where it should stand.

    Tags an app declares carry a ``name`` unique on their wall, so declaring them
    again keeps their codes (printed or photographed codes keep working).
    """

    __tablename__ = "tags"
    __table_args__ = (UniqueConstraint("wall_id", "name"),)

    code: Mapped[str] = mapped_column(String(16), primary_key=True)
    wall_id: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    name: Mapped[str | None] = mapped_column(String(100))
    label: Mapped[str] = mapped_column(String(200), nullable=False, default="")
    app: Mapped[str] = mapped_column(String(64), nullable=False)
    action: Mapped[str] = mapped_column(String(64), nullable=False)
    params: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False, default=dict)
    kind: Mapped[str] = mapped_column(String(8), nullable=False, default="url")
    content: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False, default=dict)
    tag_set: Mapped[str | None] = mapped_column(String(64))  # None: in every set
    anchor_x: Mapped[float | None] = mapped_column(Float)
    anchor_y: Mapped[float | None] = mapped_column(Float)
    screen: Mapped[str | None] = mapped_column(String(32))
    slot: Mapped[int] = mapped_column(Integer, nullable=False, default=0)
    size_mm: Mapped[float | None] = mapped_column(Float)
    clear_mm: Mapped[float | None] = mapped_column(Float)  # keep-clear half-side, anchored tags
    priority: Mapped[int] = mapped_column(Integer, nullable=False, default=0)
    active: Mapped[bool] = mapped_column(nullable=False, default=True)
    expires_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
    created_by: Mapped[str] = mapped_column(String(100), nullable=False, default="")


class ScanRecord(Base):
    """One resolved scan: which code, which visitor, when, from where."""

    __tablename__ = "scans"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    code: Mapped[str] = mapped_column(
        String(16), ForeignKey("tags.code", ondelete="CASCADE"), index=True, nullable=False
    )
    wall_id: Mapped[str] = mapped_column(String(64), nullable=False)
    visitor_id: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    scanned_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, index=True, nullable=False
    )
    client_address: Mapped[str] = mapped_column(String(64), nullable=False, default="")
    user_agent: Mapped[str] = mapped_column(String(400), nullable=False, default="")


class TagLayoutRecord(Base):
    """Where a wall's codes stand for one tag set: a placement, kept immutable.

    The wall state names the layout in use; tiles fetch it by id, so a layout can be
    cached forever, and a new placement is a new row.
    """

    __tablename__ = "tag_layouts"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    wall_id: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    tag_set: Mapped[str | None] = mapped_column(String(64))
    inputs_hash: Mapped[str] = mapped_column(String(64), nullable=False)
    placed: Mapped[list[dict[str, Any]]] = mapped_column(JSON, nullable=False)
    unplaced: Mapped[list[dict[str, Any]]] = mapped_column(JSON, nullable=False)
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class AccountRecord(Base):
    """An instructor or admin: a local account signs in with a password (argon2 hash,
    never the text), a campus account through its OpenID provider (``issuer`` and the
    provider's ``subject`` for the person; no password)."""

    __tablename__ = "accounts"
    __table_args__ = (UniqueConstraint("issuer", "subject"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    username: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    role: Mapped[str] = mapped_column(String(16), nullable=False)
    password_hash: Mapped[str | None] = mapped_column(String(200), nullable=True)
    issuer: Mapped[str | None] = mapped_column(String(500), nullable=True)
    subject: Mapped[str | None] = mapped_column(String(255), nullable=True)
    # As the provider names the person (its ``name`` claim), updated at each sign-in.
    full_name: Mapped[str] = mapped_column(String(80), nullable=False, default="")
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class VisitorRecord(Base):
    """A phone (or browser) that has been given something: a role, a group, a name.

    ``id`` is stable for the life of the cookie; ``session_id`` rotates on every
    privilege change, so a session id seen before the change is worthless after it.
    ``authority`` says what allows a role above student (``login:NAME``,
    ``pairing:NAME``, ``operator``, ``address:CIDR``) and ``authorized_role`` how
    far; both outlive a step down to student, so the phone can step up again
    without signing in again.
    """

    __tablename__ = "visitors"

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    session_id: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    role: Mapped[str] = mapped_column(String(16), nullable=False, default="student")
    authority: Mapped[str | None] = mapped_column(String(120), index=True)
    authorized_role: Mapped[str] = mapped_column(String(16), nullable=False, default="student")
    user_group: Mapped[str | None] = mapped_column(String(16))
    info_class: Mapped[int | None] = mapped_column(Integer)
    display_name: Mapped[str] = mapped_column(String(60), nullable=False, default="")
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
    updated_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, onupdate=_utcnow, nullable=False
    )


class ClassRecord(Base):
    """A class held at a wall: from Start class to End class, how its students are
    named, who started and ended it. At most one class of a wall runs at a time."""

    __tablename__ = "classes"
    __table_args__ = (
        Index(
            "ix_classes_one_running",
            "wall_id",
            unique=True,
            postgresql_where=text("ended_at IS NULL"),
            sqlite_where=text("ended_at IS NULL"),
        ),
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    wall_id: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    title: Mapped[str] = mapped_column(String(80), nullable=False)
    names: Mapped[str] = mapped_column(String(16), nullable=False, default="anonymous")
    started_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
    started_by: Mapped[str] = mapped_column(String(120), nullable=False, default="")
    ended_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    ended_by: Mapped[str | None] = mapped_column(String(120), nullable=True)


class ClassMemberRecord(Base):
    """A student who joined a class, with the name the class asked for ("" when it
    asked none)."""

    __tablename__ = "class_members"

    class_id: Mapped[int] = mapped_column(
        Integer, ForeignKey("classes.id", ondelete="CASCADE"), primary_key=True
    )
    visitor_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    name: Mapped[str] = mapped_column(String(60), nullable=False, default="")
    joined_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class AddressRuleRecord(Base):
    """Defaults (and, when enabled, a role) for phones whose address is in ``network``."""

    __tablename__ = "address_rules"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    network: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    role: Mapped[str | None] = mapped_column(String(16))
    user_group: Mapped[str | None] = mapped_column(String(16))
    info_class: Mapped[int | None] = mapped_column(Integer)
    note: Mapped[str] = mapped_column(String(200), nullable=False, default="")
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class PairingRecord(Base):
    """A single-use pairing code shown on a dashboard; only its hash is stored."""

    __tablename__ = "pairings"

    token_hash: Mapped[str] = mapped_column(String(64), primary_key=True)
    granted_by: Mapped[str] = mapped_column(String(120), nullable=False)
    expires_at: Mapped[datetime] = mapped_column(DateTime(timezone=True), nullable=False)
    used_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    used_by: Mapped[str | None] = mapped_column(String(64))
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class AuditRecord(Base):
    """Who signed in, failed to, or changed whose privileges: kept for the admin."""

    __tablename__ = "audit_log"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, index=True, nullable=False
    )
    action: Mapped[str] = mapped_column(String(32), index=True, nullable=False)
    actor: Mapped[str] = mapped_column(String(120), nullable=False, default="")
    visitor_id: Mapped[str] = mapped_column(String(64), nullable=False, default="")
    client_address: Mapped[str] = mapped_column(String(64), nullable=False, default="")
    detail: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False, default=dict)


class PublicationRecord(Base):
    """Something a visitor published to a wall's public screen, and what became of it."""

    __tablename__ = "publications"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    wall_id: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    visitor_id: Mapped[str] = mapped_column(String(64), nullable=False)
    author: Mapped[str] = mapped_column(String(100), nullable=False)
    title: Mapped[str] = mapped_column(String(200), nullable=False)
    html: Mapped[str] = mapped_column(Text, nullable=False)
    source: Mapped[str] = mapped_column(String(200), nullable=False, default="")
    status: Mapped[str] = mapped_column(String(16), index=True, nullable=False)
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
    decided_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))
    decided_by: Mapped[str] = mapped_column(String(120), nullable=False, default="")


class CensusDataSetRecord(Base):
    """An imported census data set; the ``current`` one is what the census map shows."""

    __tablename__ = "census_datasets"
    # At most one current data set, whatever races (two server processes seeding the
    # shipped one at the same start): the database says no to the second.
    __table_args__ = (
        Index(
            "ix_census_datasets_one_current",
            "current",
            unique=True,
            postgresql_where=text('"current"'),
            sqlite_where=text('"current"'),
        ),
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(64), index=True, nullable=False)
    settings: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    source: Mapped[str] = mapped_column(String(500), nullable=False, default="")
    tract_count: Mapped[int] = mapped_column(Integer, nullable=False)
    current: Mapped[bool] = mapped_column(nullable=False, default=False)
    created_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class CensusTractRecord(Base):
    """One tract of a data set: its outline (GeoJSON, longitude/latitude) and values."""

    __tablename__ = "census_tracts"

    dataset_id: Mapped[int] = mapped_column(
        ForeignKey("census_datasets.id", ondelete="CASCADE"), primary_key=True
    )
    geoid: Mapped[str] = mapped_column(String(64), primary_key=True)
    geometry: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    values: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)


class QuizRoundRecord(Base):
    """A round of an app's quiz on a wall (:mod:`webapp.quiz`); a new round starts the
    next number, and earlier rounds' answers stay for export."""

    __tablename__ = "quiz_rounds"

    app: Mapped[str] = mapped_column(String(64), primary_key=True)
    wall_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    number: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    started_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
    started_by: Mapped[str] = mapped_column(String(120), nullable=False, default="")
    # Per set, the item ids in question order: question n is the n-th (a fresh random
    # order each round, so no number names an item for long).
    orders: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False, default=dict)
    # When students see the correct answers: when the round closes, or at finishing.
    reveal: Mapped[str] = mapped_column(String(16), nullable=False, default="close")
    closed_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)
    closed_by: Mapped[str | None] = mapped_column(String(120), nullable=True)
    # Written by every answer before it is stored: the row lock orders answers and the
    # closing of the round, so no answer lands in a closed round.
    last_answer_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True), nullable=True)


class QuizAnswerRecord(Base):
    """A visitor's answer for one item of a set, in one round (changeable until the
    visitor finishes that set, unless given final: a poll's)."""

    __tablename__ = "quiz_answers"
    __table_args__ = (
        UniqueConstraint("app", "wall_id", "round", "visitor_id", "set_name", "item_id"),
    )

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    app: Mapped[str] = mapped_column(String(64), nullable=False)
    wall_id: Mapped[str] = mapped_column(String(64), nullable=False)
    round: Mapped[int] = mapped_column(Integer, nullable=False)
    visitor_id: Mapped[str] = mapped_column(String(64), nullable=False)
    set_name: Mapped[str] = mapped_column(String(64), nullable=False)
    item_id: Mapped[str] = mapped_column(String(64), nullable=False)
    answer: Mapped[str] = mapped_column(String(200), nullable=False)
    correct: Mapped[bool | None] = mapped_column(nullable=True)  # None: not judged (a poll)
    final: Mapped[bool] = mapped_column(nullable=False, default=False)  # never changed
    answered_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, onupdate=_utcnow, nullable=False
    )


class QuizFinishRecord(Base):
    """A visitor finished a set's quiz in a round: answers are final, results shown."""

    __tablename__ = "quiz_finishes"

    app: Mapped[str] = mapped_column(String(64), primary_key=True)
    wall_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    round: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    visitor_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    set_name: Mapped[str] = mapped_column(String(64), primary_key=True)
    finished_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )


class BrainWallRecord(Base):
    """The brain atlas's choices for one wall that outlive rounds: whether scanning a
    user group on the menu switches the wall's pins, and when the audience last did."""

    __tablename__ = "brain_walls"

    wall_id: Mapped[str] = mapped_column(String(64), primary_key=True)
    audience_switches: Mapped[bool] = mapped_column(nullable=False, default=False)
    audience_switched_at: Mapped[datetime | None] = mapped_column(
        DateTime(timezone=True), nullable=True
    )


class TokenSaltRecord(Base):
    """A random salt mixed into one token (``operator``, ``tile:WALL``): replacing it
    rotates that token without touching the secret key (sessions stay valid)."""

    __tablename__ = "token_salts"

    purpose: Mapped[str] = mapped_column(String(80), primary_key=True)
    salt: Mapped[str] = mapped_column(String(64), nullable=False)
    rotated_at: Mapped[datetime] = mapped_column(
        DateTime(timezone=True), default=_utcnow, nullable=False
    )
