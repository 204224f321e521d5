"""Instructor and admin accounts: argon2 password hashes, never the passwords."""

from __future__ import annotations

import re

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.core.roles import Role
from webapp.database.connection import Database
from webapp.database.models import AccountRecord
from webapp.people.audit import audit
from webapp.people.person import revoke

ACCOUNT_ROLES: tuple[Role, ...] = ("instructor", "admin")
MIN_PASSWORD_LENGTH = 8
USERNAME = re.compile(r"^[a-z0-9][a-z0-9._-]{1,62}$")


class AccountError(ValueError):
    """A request about accounts that cannot be carried out; the message says why."""


def _hasher() -> PasswordHasher:
    return PasswordHasher()


def check_password(password: str) -> None:
    if len(password) < MIN_PASSWORD_LENGTH:
        raise AccountError(f"a password needs at least {MIN_PASSWORD_LENGTH} characters")


def normalize_username(username: str) -> str:
    name = username.strip().lower()
    if not USERNAME.match(name):
        raise AccountError(f"{username!r} is not a valid username: 2-63 of a-z, 0-9, '.', '_', '-'")
    return name


def add_account(db: Database, username: str, role: str, password: str, actor: str) -> AccountRecord:
    name = normalize_username(username)
    if role not in ACCOUNT_ROLES:
        raise AccountError(f"role must be one of {', '.join(ACCOUNT_ROLES)}, not {role!r}")
    check_password(password)
    record = AccountRecord(username=name, role=role, password_hash=_hasher().hash(password))
    try:
        with db.session() as session:
            session.add(record)
            session.flush()
            audit(session, "account_added", actor=actor, username=name, role=role)
    except IntegrityError:
        raise AccountError(f"there is already an account called {name!r}") from None
    return record


def _find(session: Session, username: str) -> AccountRecord | None:
    """The account called ``username`` in any case; a name no account can have (one
    with a NUL byte, which PostgreSQL would refuse to compare) is looked up nowhere."""
    name = username.strip().lower()
    if not USERNAME.match(name):
        return None
    return session.scalar(select(AccountRecord).where(AccountRecord.username == name))


def list_accounts(db: Database) -> list[AccountRecord]:
    with db.session() as session:
        return list(session.scalars(select(AccountRecord).order_by(AccountRecord.username)))


def _account_authorities(username: str) -> list[str]:
    return [f"login:{username}", f"pairing:{username}"]


def remove_account(db: Database, username: str, actor: str) -> None:
    """Delete the account and demote every phone it authorised."""
    name = username.strip().lower()
    with db.session() as session:
        record = _find(session, name)
        if record is None:
            raise AccountError(f"there is no account called {name!r}")
        session.delete(record)
        audit(session, "account_removed", actor=actor, username=name)
    revoke(db, _account_authorities(name), actor)


def set_password(db: Database, username: str, password: str, actor: str) -> None:
    """A new password; phones signed in with the old one are signed out."""
    check_password(password)
    name = username.strip().lower()
    with db.session() as session:
        record = _find(session, name)
        if record is None:
            raise AccountError(f"there is no account called {name!r}")
        record.password_hash = _hasher().hash(password)
        audit(session, "password_changed", actor=actor, username=name)
    revoke(db, _account_authorities(name), actor)


# Verified against when the username is unknown, so timing does not tell which names exist.
_DUMMY_HASH = (
    "$argon2id$v=19$m=65536,t=3,p=4$c29tZXNhbHRzb21lc2FsdA$"
    "2KwX8k3JvE0C+o0kK3pY9n0l1o0f7gC3n1x3m7q1d5E"
)


def authenticate(db: Database, username: str, password: str) -> AccountRecord | None:
    """The account if the password is right, else None (same cost either way)."""
    with db.session() as session:
        record = _find(session, username)
        hasher = _hasher()
        try:
            hasher.verify(record.password_hash if record else _DUMMY_HASH, password)
        except (VerificationError, InvalidHashError):
            return None
        if record is None:
            return None
        if hasher.check_needs_rehash(record.password_hash):
            record.password_hash = hasher.hash(password)
        return record
