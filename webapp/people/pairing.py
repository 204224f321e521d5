"""Pairing: a phone becomes instructor by scanning a code on a signed-in dashboard.

The code is single use and short lived (``TAGWALL_PAIRING_TTL_S``); only its hash is
stored, and redeeming it is one conditional UPDATE, so two phones racing for the
same code cannot both win.
"""

from __future__ import annotations

import hashlib
import secrets
from datetime import UTC, datetime, timedelta

from sqlalchemy import update

from tag_service.codes import ALPHABET
from webapp.database.connection import Database, as_utc
from webapp.database.models import PairingRecord

TOKEN_LENGTH = 26  # 36**26: about 134 bits, in QR alphanumeric mode


class PairingError(Exception):
    """A pairing code that cannot be redeemed; ``status`` is the HTTP status to answer."""

    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


def _hash(token: str) -> str:
    return hashlib.sha256(token.upper().encode()).hexdigest()


def _now() -> datetime:
    return datetime.now(UTC)


def start_pairing(db: Database, granted_by: str, ttl_s: int) -> tuple[str, datetime]:
    """A new pairing code from ``granted_by`` (an account name or ``operator``)."""
    token = "".join(secrets.choice(ALPHABET) for _ in range(TOKEN_LENGTH))
    expires_at = _now() + timedelta(seconds=ttl_s)
    with db.session() as session:
        session.add(
            PairingRecord(token_hash=_hash(token), granted_by=granted_by, expires_at=expires_at)
        )
    return token, expires_at


def check_pairing(db: Database, token: str) -> str:
    """Who granted ``token`` if it can be redeemed now; else :class:`PairingError`."""
    with db.session() as session:
        record = session.get(PairingRecord, _hash(token))
    _explain(record)
    assert record is not None
    return record.granted_by


def redeem(db: Database, token: str, visitor_id: str) -> str:
    """Use ``token`` up for ``visitor_id``; returns who granted it."""
    token_hash = _hash(token)
    now = _now()
    with db.session() as session:
        result = session.execute(
            update(PairingRecord)
            .where(
                PairingRecord.token_hash == token_hash,
                PairingRecord.used_at.is_(None),
                PairingRecord.expires_at > now,
            )
            .values(used_at=now, used_by=visitor_id)
        )
        record = session.get(PairingRecord, token_hash)
        if result.rowcount == 1 and record is not None:  # type: ignore[attr-defined]
            return record.granted_by
    _explain(record)
    raise PairingError(410, "This pairing code can no longer be used.")


def _explain(record: PairingRecord | None) -> None:
    if record is None:
        raise PairingError(404, "This is not a pairing code of this wall.")
    if record.used_at is not None:
        raise PairingError(410, "This pairing code was already used. Ask for a new one.")
    if as_utc(record.expires_at) <= _now():
        raise PairingError(410, "This pairing code has expired. Ask for a new one.")
