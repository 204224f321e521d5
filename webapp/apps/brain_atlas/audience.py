"""Who switches the wall's pins: the instructor always; the audience only where the
instructor allows it, not during a running quiz round, and at most once per cooldown.

A phone's user group belongs to the phone. The dissertation's menu screen reloaded the
wall's codes for everybody when someone scanned a group; in a room that is one child's
scan removing the medical students' pins mid-quiz, or a few phones flipping the wall
back and forth. So the wall follows the audience only as an option the instructor
chooses on the dashboard, and a switch claims the wall's cooldown atomically in the
database (every server process sees the same claim).
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

from sqlalchemy import or_, update
from sqlalchemy.exc import IntegrityError

from webapp.database.connection import Database
from webapp.database.models import BrainWallRecord


def _ensure(db: Database, wall_id: str) -> None:
    try:
        with db.session() as session:
            if session.get(BrainWallRecord, wall_id) is None:
                session.add(BrainWallRecord(wall_id=wall_id, audience_switches=False))
    except IntegrityError:  # made by another request meanwhile
        pass


def audience_switches(db: Database, wall_id: str) -> bool:
    """Whether scanning a user group on the menu screen switches the wall's pins."""
    with db.session() as session:
        record = session.get(BrainWallRecord, wall_id)
        return bool(record and record.audience_switches)


def allow_audience_switches(db: Database, wall_id: str, allowed: bool) -> None:
    """The instructor's choice (off unless chosen: the dissertation's behaviour)."""
    _ensure(db, wall_id)
    with db.session() as session:
        session.execute(
            update(BrainWallRecord)
            .where(BrainWallRecord.wall_id == wall_id)
            .values(audience_switches=allowed)
        )


def claim_audience_switch(db: Database, wall_id: str, cooldown_s: float) -> bool:
    """True when this request may switch the wall now: the audience may, and the
    wall's last audience switch is at least ``cooldown_s`` ago. Claiming stamps the
    time in one conditional UPDATE, so of many scans at once exactly one wins."""
    now = datetime.now(UTC)
    with db.session() as session:
        claimed = session.execute(
            update(BrainWallRecord)
            .where(
                BrainWallRecord.wall_id == wall_id,
                BrainWallRecord.audience_switches.is_(True),
                or_(
                    BrainWallRecord.audience_switched_at.is_(None),
                    BrainWallRecord.audience_switched_at <= now - timedelta(seconds=cooldown_s),
                ),
            )
            .values(audience_switched_at=now)
        )
        return claimed.rowcount == 1  # type: ignore[attr-defined,no-any-return]
