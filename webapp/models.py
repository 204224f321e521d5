"""Database tables (SQLAlchemy 2 typed models); wire schemas live in pydantic models."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import JSON, DateTime, Float, ForeignKey, Integer, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column

from webapp.db import Base


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
