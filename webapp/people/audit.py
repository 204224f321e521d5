"""The audit log: sign-ins, failed sign-ins and every privilege change, for the admin."""

from __future__ import annotations

from typing import Any

from sqlalchemy import Connection, insert, select
from sqlalchemy.orm import Session

from webapp.database.connection import Database
from webapp.database.models import AuditRecord


def audit(
    writer: Session | Connection,
    action: str,
    *,
    actor: str = "",
    visitor_id: str = "",
    address: str = "",
    **detail: Any,
) -> None:
    """Add one entry in the caller's transaction, so it lands with the change it records."""
    writer.execute(
        insert(AuditRecord).values(
            action=action,
            actor=actor[:120],
            visitor_id=visitor_id,
            client_address=address[:64],
            detail=detail,
        )
    )


def recent_entries(db: Database, limit: int = 100) -> list[AuditRecord]:
    with db.session() as session:
        return list(
            session.scalars(select(AuditRecord).order_by(AuditRecord.id.desc()).limit(limit)).all()
        )
