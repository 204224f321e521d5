"""Database tables (SQLAlchemy 2 typed models); wire schemas live in pydantic models."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import JSON, DateTime, Integer, String
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
