"""Single-use passes of the LTI flows, kept on the server: the random value travels in
a form or a URL, only its SHA-256 is stored, and taking it marks it used in one
conditional UPDATE, so two requests bearing the same pass cannot both get it.

They carry what a cookie would carry elsewhere: the platform's iframe gets no
third-party cookies in Safari (nor in Chrome with them blocked), so a launch keeps its
``state`` and ``nonce`` here."""

from __future__ import annotations

import hashlib
import secrets
from datetime import UTC, datetime, timedelta
from typing import Any, Literal

from sqlalchemy import delete, insert, select, update

from webapp.database.connection import Database
from webapp.database.models import LtiPassRecord

Purpose = Literal["state", "choice", "handover"]
LIFETIMES: dict[Purpose, timedelta] = {
    "state": timedelta(minutes=10),  # login initiation to launch: a few redirects
    "choice": timedelta(hours=1),  # an instructor choosing a deep link's wall and lesson
    "handover": timedelta(minutes=10),  # a launch page to the page it opens
}


def _digest(value: str) -> str:
    return hashlib.sha256(value.encode()).hexdigest()


def issue(db: Database, purpose: Purpose, payload: dict[str, Any]) -> str:
    """A new pass for ``purpose`` carrying ``payload``; its value (never stored)."""
    value = secrets.token_urlsafe(32)
    now = datetime.now(UTC)
    with db.engine.begin() as connection:
        connection.execute(delete(LtiPassRecord).where(LtiPassRecord.expires_at < now))
        connection.execute(
            insert(LtiPassRecord).values(
                digest=_digest(value),
                purpose=purpose,
                payload=payload,
                expires_at=now + LIFETIMES[purpose],
            )
        )
    return value


def take(db: Database, purpose: Purpose, value: str) -> dict[str, Any] | None:
    """The payload of the pass ``value`` for ``purpose``, marked used; None when there is
    no such pass, it expired, or it was taken before."""
    if not value or len(value) > 100:
        return None
    digest, now = _digest(value), datetime.now(UTC)
    with db.engine.begin() as connection:
        taken = connection.execute(
            update(LtiPassRecord)
            .where(
                LtiPassRecord.digest == digest,
                LtiPassRecord.purpose == purpose,
                LtiPassRecord.used_at.is_(None),
                LtiPassRecord.expires_at > now,
            )
            .values(used_at=now)
        ).rowcount
        if not taken:
            return None
        payload: dict[str, Any] = connection.execute(
            select(LtiPassRecord.payload).where(LtiPassRecord.digest == digest)
        ).scalar_one()
    return payload
