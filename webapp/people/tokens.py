"""The operator's and the tiles' tokens as they stand now, and their rotation.

A token is derived from the secret key and a salt per purpose (``operator``,
``tile:WALL``) stored in the database; rotating a token replaces its salt, so the old
token stops working everywhere while sessions (signed with the secret key itself) stay
valid. Servers read the salts at start and every :data:`REFRESH_S` seconds, so a
rotation made by ``tagwall tokens rotate`` reaches every server process.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime

from sqlalchemy import select
from sqlalchemy.exc import OperationalError, ProgrammingError

from webapp.database.connection import Database
from webapp.database.models import TokenSaltRecord
from webapp.people.audit import audit
from webapp.people.security import operator_token, tile_token

REFRESH_S = 5.0
OPERATOR = "operator"


def tile_purpose(wall_id: str) -> str:
    return f"tile:{wall_id}"


@dataclass(frozen=True)
class Tokens:
    """The tokens derived from ``secret`` and the stored ``salts``."""

    secret: str
    salts: Mapping[str, str] = field(default_factory=dict)

    def tile(self, wall_id: str) -> str:
        return tile_token(self.secret, wall_id, self.salts.get(tile_purpose(wall_id), ""))

    @property
    def operator(self) -> str:
        return operator_token(self.secret, self.salts.get(OPERATOR, ""))


def load_tokens(db: Database, secret: str) -> Tokens:
    """The tokens as stored now (the unrotated ones on a database never migrated)."""
    try:
        with db.session() as session:
            rows = session.execute(select(TokenSaltRecord.purpose, TokenSaltRecord.salt)).all()
    except (OperationalError, ProgrammingError) as error:
        if "token_salts" not in str(error.orig):
            raise
        rows = []  # a database before migration 0008: nothing was ever rotated
    return Tokens(secret, {purpose: salt for purpose, salt in rows})


def rotate(db: Database, purposes: Iterable[str], actor: str) -> None:
    """New salts for ``purposes``: their old tokens stop working."""
    with db.session() as session:
        for purpose in purposes:
            record = session.get(TokenSaltRecord, purpose)
            if record is None:
                record = TokenSaltRecord(purpose=purpose, salt="")
                session.add(record)
            record.salt = secrets.token_urlsafe(16)
            record.rotated_at = datetime.now(UTC)
            audit(session, "token_rotated", actor=actor, purpose=purpose)
