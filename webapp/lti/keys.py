"""tagwall's own keys as an LTI tool: the newest signs its messages (deep-linking
responses, client assertions for service tokens); the published key set keeps a retired
key for ``TAGWALL_LTI_KEY_OVERLAP_H`` hours, so what it signed just before a rotation
still verifies at the platform."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from typing import Any

from joserfc.jwk import RSAKey
from sqlalchemy import select, update

from webapp.database.connection import Database, as_utc
from webapp.database.models import LtiKeyRecord
from webapp.people.audit import audit

KEY_BITS = 2048
ALGORITHM = "RS256"  # the one LTI 1.3 requires of every platform and tool


def _new_key() -> RSAKey:
    return RSAKey.generate_key(
        KEY_BITS, parameters={"use": "sig", "alg": ALGORITHM}, private=True, auto_kid=True
    )


def signing_key(db: Database) -> RSAKey:
    """The key tagwall signs with now (made on first use)."""
    with db.session() as session:
        record = session.scalars(
            select(LtiKeyRecord)
            .where(LtiKeyRecord.retired_at.is_(None))
            .order_by(LtiKeyRecord.created_at.desc())
            .limit(1)
        ).first()
        if record is None:
            key = _new_key()
            session.add(LtiKeyRecord(kid=key.kid, private_jwk=key.as_dict(private=True)))
            return key
        return RSAKey.import_key(record.private_jwk)


def public_key_set(db: Database, overlap_h: float) -> list[dict[str, Any]]:
    """The public keys the platforms verify tagwall with: the signing key and those
    retired less than ``overlap_h`` hours ago."""
    signing_key(db)
    since = datetime.now(UTC) - timedelta(hours=overlap_h)
    with db.reading() as connection:
        rows = connection.execute(
            select(LtiKeyRecord.private_jwk, LtiKeyRecord.retired_at).order_by(
                LtiKeyRecord.created_at.desc()
            )
        ).all()
    return [
        RSAKey.import_key(row.private_jwk).as_dict(private=False)
        for row in rows
        if row.retired_at is None or as_utc(row.retired_at) > since
    ]


def rotate_keys(db: Database, actor: str) -> str:
    """A new signing key; the one before it is retired (still published for a while).
    Returns the new key's id."""
    key = _new_key()
    now = datetime.now(UTC)
    with db.session() as session:
        session.execute(
            update(LtiKeyRecord).where(LtiKeyRecord.retired_at.is_(None)).values(retired_at=now)
        )
        session.add(LtiKeyRecord(kid=key.kid, private_jwk=key.as_dict(private=True)))
        audit(session, "token_rotated", actor=actor, purpose="lti", kid=key.kid)
    return str(key.kid)
