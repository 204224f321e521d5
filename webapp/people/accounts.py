"""Instructor and admin accounts: local ones with argon2 password hashes (never the
passwords), campus ones named by their OpenID provider (issuer and subject)."""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.core.roles import Role
from webapp.database.connection import Database
from webapp.database.models import AccountRecord
from webapp.people.audit import audit
from webapp.people.person import rank, revoke

ACCOUNT_ROLES: tuple[Role, ...] = ("instructor", "admin")
MIN_PASSWORD_LENGTH = 8
USERNAME = re.compile(r"^[a-z0-9][a-z0-9._-]{1,62}$")
_NOT_IN_USERNAMES = re.compile(r"[^a-z0-9._-]+")
# Tries at a campus account's first sign-in when another takes the same name meanwhile.
_FIRST_SIGN_IN_TRIES = 3


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


@dataclass(frozen=True)
class CampusIdentity:
    """A person as their campus's OpenID provider vouched for them at a sign-in."""

    issuer: str
    subject: str
    name_hint: str  # what the username is made from: preferred_username, email, ...
    full_name: str


def _username_base(hint: str) -> str:
    """A username from a provider's name for the person (``Zoë.Ng@example.edu`` gives
    ``zoe.ng``): the local part, accents folded, what usernames cannot hold a dash."""
    local = hint.strip().partition("@")[0]
    ascii_only = unicodedata.normalize("NFKD", local).encode("ascii", "ignore").decode()
    base = _NOT_IN_USERNAMES.sub("-", ascii_only.lower()).strip("._-")[:56]
    return base if len(base) >= 2 else "staff"


def _free_username(session: Session, hint: str) -> str:
    """The hint's username, else the first of ``NAME-2``, ``NAME-3``, ... no account
    has: a campus account never takes a local account's name (nor its phones)."""
    base = _username_base(hint)
    taken = set(
        session.scalars(
            select(AccountRecord.username).where(AccountRecord.username.startswith(base))
        )
    )
    return next(
        name
        for name in (base, *(f"{base}-{n}" for n in range(2, len(taken) + 3)))
        if name not in taken
    )


def _campus_record(session: Session, issuer: str, subject: str) -> AccountRecord | None:
    return session.scalar(
        select(AccountRecord).where(
            AccountRecord.issuer == issuer, AccountRecord.subject == subject
        )
    )


def campus_account(db: Database, identity: CampusIdentity, role: Role, actor: str) -> AccountRecord:
    """The account of ``identity``: made at its first sign-in (under a username of its
    own), its name and role as the provider's claims say at every later one. A lower
    role than before signs out the phones the account signed in or paired."""
    tries = 1
    while True:
        try:
            record, before = _write_campus_account(db, identity, role, actor)
            break
        except IntegrityError:  # a first sign-in of the same name or person meanwhile
            if tries == _FIRST_SIGN_IN_TRIES:
                raise
            tries += 1
    if before is not None and rank(role) < rank(before):
        revoke(db, _account_authorities(record.username), actor)
    return record


def _write_campus_account(
    db: Database, identity: CampusIdentity, role: Role, actor: str
) -> tuple[AccountRecord, str | None]:
    """The account written, and its role before (None: it is new)."""
    with db.session() as session:
        record = _campus_record(session, identity.issuer, identity.subject)
        before = record.role if record else None
        if record is None:
            record = AccountRecord(
                username=_free_username(session, identity.name_hint),
                issuer=identity.issuer,
                subject=identity.subject,
            )
            session.add(record)
        record.role = role
        record.full_name = identity.full_name
        session.flush()
        if before is None:
            audit(
                session,
                "account_added",
                actor=actor,
                username=record.username,
                role=role,
                issuer=identity.issuer,
            )
        elif before != role:
            audit(
                session,
                "account_role_changed",
                actor=actor,
                username=record.username,
                role=role,
                was=before,
            )
    return record, before


def forget_campus_account(db: Database, issuer: str, subject: str, actor: str) -> str | None:
    """Remove the campus account of this person, whom the provider's claims no longer
    give a role, and demote its phones; its username, or None when it had none."""
    with db.session() as session:
        record = _campus_record(session, issuer, subject)
        if record is None:
            return None
        name = record.username
        session.delete(record)
        audit(session, "account_removed", actor=actor, username=name, reason="no role")
    revoke(db, _account_authorities(name), actor)
    return name


def campus_issuer(db: Database, username: str) -> str | None:
    """The issuer a campus account signs in at (None: a local account, or none)."""
    with db.session() as session:
        record = _find(session, username)
        return record.issuer if record else None


def set_password(db: Database, username: str, password: str, actor: str) -> None:
    """A new password; phones signed in with the old one are signed out."""
    check_password(password)
    name = username.strip().lower()
    with db.session() as session:
        record = _find(session, name)
        if record is None:
            raise AccountError(f"there is no account called {name!r}")
        if record.issuer:
            raise AccountError(f"{name} signs in at {record.issuer}: it has no password here")
        record.password_hash = _hasher().hash(password)
        audit(session, "password_changed", actor=actor, username=name)
    revoke(db, _account_authorities(name), actor)


# Verified against when the username is unknown, so timing does not tell which names exist.
_DUMMY_HASH = (
    "$argon2id$v=19$m=65536,t=3,p=4$c29tZXNhbHRzb21lc2FsdA$"
    "2KwX8k3JvE0C+o0kK3pY9n0l1o0f7gC3n1x3m7q1d5E"
)


def authenticate(db: Database, username: str, password: str) -> AccountRecord | None:
    """The account if the password is right, else None (same cost either way; a campus
    account has no password)."""
    with db.session() as session:
        record = _find(session, username)
        stored = record.password_hash if record else None
        hasher = _hasher()
        try:
            hasher.verify(stored or _DUMMY_HASH, password)
        except (VerificationError, InvalidHashError):
            return None
        if record is None or stored is None:
            return None
        if hasher.check_needs_rehash(stored):
            record.password_hash = hasher.hash(password)
        return record
