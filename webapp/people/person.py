"""People: a visitor's role, user group and information class, and the one place
each of them changes.

A phone is an anonymous visitor until it is given something; then a row in
``visitors`` holds it. Every privilege change goes through :func:`_store` with
``rotate=True``: the session id changes, so a cookie copied before the change is
worth nothing after it, and the change is written to the audit log in the same
transaction.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache, partial
from typing import Any, ParamSpec, TypeVar

from sqlalchemy import Connection, Insert, Row, Update, bindparam, insert, select, update
from starlette.requests import HTTPConnection

from webapp.core.roles import ROLES, Role, UserGroup
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import VisitorRecord
from webapp.people.addresses import AddressRules, matching_rule, read_rules
from webapp.people.audit import audit
from webapp.people.visitors import Visitor, adopt, new_id, visitor_of

ROLE_LABELS: dict[Role, str] = {
    "student": "Student",
    "instructor": "Instructor",
    "admin": "Administrator",
}
# How the public screen names someone who chose no name: the role with its article,
# written out ("an instructor", never "a instructor").
SOMEONE_IN_ROLE: dict[Role, str] = {
    "student": "a student",
    "instructor": "an instructor",
    "admin": "an administrator",
}
GROUP_LABELS: dict[UserGroup, str] = {
    "k5": "K-5",
    "undergraduate": "Undergraduate",
    "medical": "Medical",
    "research": "Research",
}


P = ParamSpec("P")
T = TypeVar("T")

MAX_DISPLAY_NAME = 40


def plain_text(text: str) -> str:
    """Text people type as tagwall keeps it: one line, runs of spaces as one, no
    control, format (bidirectional overrides, zero-width) or private-use characters
    (nor a NUL byte, which PostgreSQL cannot store)."""
    kept = "".join(
        " " if char.isspace() else char
        for char in text
        if char.isspace() or not unicodedata.category(char).startswith("C")
    )
    return " ".join(kept.split())


def plain_name(text: str) -> str:
    """A display name as the public screen may show it: plain text with compatibility
    characters folded (NFKC), at most :data:`MAX_DISPLAY_NAME` characters."""
    return plain_text(unicodedata.normalize("NFKC", text))[:MAX_DISPLAY_NAME].strip()


def rank(role: str) -> int:
    """Privilege order: student < instructor < admin (unknown roles rank lowest)."""
    return ROLES.index(role) if role in ROLES else -1


@dataclass(frozen=True)
class Person:
    """Who is asking, as every privilege check sees it."""

    visitor: Visitor
    role: Role
    authority: str | None
    authorized_role: Role
    user_group: UserGroup
    info_class: int
    max_info_class: int
    display_name: str
    stored: bool  # False: an anonymous visitor nobody gave anything yet

    def at_least(self, role: Role) -> bool:
        return rank(self.role) >= rank(role)

    @property
    def is_staff(self) -> bool:
        """Instructors and admins: who runs a session."""
        return self.at_least("instructor")

    def may_assume(self, role: Role) -> bool:
        """Whether this phone's authority reaches ``role`` without signing in again."""
        return rank(role) <= rank(self.authorized_role)

    @property
    def public_name(self) -> str:
        """How the public screen names this person: the role always shows, so a chosen
        name cannot pass for someone else's (no student publishes as "the instructor")."""
        if not self.display_name:
            return SOMEONE_IN_ROLE[self.role]
        return f"{self.display_name} ({ROLE_LABELS[self.role].lower()})"


# Every request of a phone reads these: built once (see Database.reading).
_VISITOR = select(VisitorRecord.__table__).where(VisitorRecord.id == bindparam("id"))


def load_person(
    db: Database,
    visitor: Visitor,
    address: str,
    settings: Settings,
    rules_of: Callable[[Connection], Sequence[Row[Any]]] = read_rules,
) -> Person:
    """The person behind ``visitor`` coming from ``address``; the address rules from
    ``rules_of`` (a request's: the app's :class:`AddressRules`).

    A cookie whose session id no longer matches (copied before a rotation, or
    kept past a sign-out elsewhere) is treated as a new, anonymous visitor.
    """
    with db.reading() as connection:
        record = connection.execute(_VISITOR, {"id": visitor.id}).first()
        rules = rules_of(connection)
    if record is not None and record.session_id != visitor.session_id:
        visitor, record = Visitor.fresh(), None
    return _person(visitor, record, matching_rule(address, rules), settings)


def _person(
    visitor: Visitor,
    record: Row[Any] | None,
    rule: Row[Any] | None,
    settings: Settings,
) -> Person:
    role: Role = _role(record.role if record else "student")
    max_class = settings.info_class_max[role]
    chosen = (record.info_class if record else None) or (rule.info_class if rule else None)
    group = (record.user_group if record else None) or (rule.user_group if rule else None)
    return Person(
        visitor=visitor,
        role=role,
        authority=record.authority if record else None,
        authorized_role=_role(record.authorized_role if record else "student"),
        user_group=group if group in GROUP_LABELS else settings.default_user_group,
        info_class=min(chosen or settings.info_class_default[role], max_class),
        max_info_class=max_class,
        display_name=record.display_name if record else "",
        stored=record is not None,
    )


def _role(value: str) -> Role:
    return value if value in ROLES else "student"


@cache
def _writes(columns: tuple[str, ...]) -> tuple[Update, Insert]:
    """The UPDATE and the INSERT of a visitor's row that write ``columns`` (values
    ``new_COLUMN``, the row ``visitor_id``), each returning the row as written: built
    once per set of columns (a phone's registration writes the same ones every time),
    so a write is one statement, not a statement built and hashed and then a read."""
    values: dict[str, Any] = {name: bindparam(f"new_{name}") for name in columns}
    row = tuple(VisitorRecord.__table__.c)
    which = VisitorRecord.id == bindparam("visitor_id")
    return (
        update(VisitorRecord).where(which).values(values).returning(*row),
        insert(VisitorRecord).values(id=bindparam("visitor_id"), **values).returning(*row),
    )


def _store(
    db: Database,
    person: Person,
    settings: Settings,
    *,
    rotate: bool,
    action: str | None = None,
    address: str = "",
    **fields: Any,
) -> Person:
    """Write ``fields`` of the person's visitor row (created if need be); the one writer.
    Core statements: every phone of a room registers through here."""
    visitor = person.visitor.rotated() if rotate else person.visitor
    values = {"session_id": visitor.session_id, **fields}
    change, add = _writes(tuple(sorted(values)))
    given = {"visitor_id": visitor.id, **{f"new_{name}": value for name, value in values.items()}}
    # A visitor made by this request (no cookie, or one a rotation outdated) has a new
    # random id no row can hold yet: one INSERT, not an UPDATE that finds nothing first.
    new = not person.stored and not person.visitor.brought_cookie
    with db.engine.begin() as connection:
        record = None if new else connection.execute(change, given).first()
        if record is None:
            record = connection.execute(add, given).one()
        if action:
            audit(
                connection,
                action,
                actor=record.authority or "",
                visitor_id=visitor.id,
                address=address,
                role=record.role,
                **{k: v for k, v in fields.items() if k in ("authority", "authorized_role")},
            )
        rules = read_rules(connection)
    return _person(visitor, record, matching_rule(address, rules), settings)


def address_grant(db: Database, address: str, settings: Settings) -> str | None:
    """The authority (``address:CIDR``) an address rule gives this client to be an
    instructor, when the deployment lets address rules grant roles at all."""
    if not settings.address_rules_grant_roles:
        return None
    with db.reading() as connection:
        rules = read_rules(connection)
    rule = matching_rule(address, rules)
    return f"address:{rule.network}" if rule is not None and rule.role == "instructor" else None


def grant(
    db: Database,
    person: Person,
    role: Role,
    authority: str,
    settings: Settings,
    address: str,
    user_group: UserGroup | None = None,
) -> Person:
    """Authorise the phone up to ``role`` on ``authority`` and act in that role (in
    ``user_group`` when the authority says which: a campus provider's rules)."""
    group = {"user_group": user_group} if user_group else {}
    return _store(
        db,
        person,
        settings,
        rotate=True,
        action="role_granted",
        address=address,
        role=role,
        authority=authority,
        authorized_role=role,
        **group,
    )


def assume(db: Database, person: Person, role: Role, settings: Settings, address: str) -> Person:
    """Act in ``role``, which the phone's authority must reach (stepping down always does)."""
    if not person.may_assume(role):
        raise PermissionError(f"this phone is not authorised as {role}")
    if person.stored and person.role == role:
        return person
    changes_privilege = role != person.role
    return _store(
        db,
        person,
        settings,
        rotate=changes_privilege,
        action="role_changed" if changes_privilege else None,
        address=address,
        role=role,
    )


def sign_out(db: Database, person: Person, settings: Settings, address: str) -> Person:
    """The phone goes on as a new anonymous visitor: the visitor signed out keeps its row
    (answers, name, group, for what the class exports) with its role and authority gone
    and its session ended, and the next person on a shared phone inherits nothing of it
    (they saw the last person's answers, name and group)."""
    _store(
        db,
        person,
        settings,
        rotate=True,
        action="logout",
        address=address,
        role="student",
        authority=None,
        authorized_role="student",
    )
    return _person(Visitor.fresh(), None, None, settings)


def update_profile(
    db: Database,
    person: Person,
    settings: Settings,
    *,
    user_group: UserGroup,
    info_class: int,
    display_name: str,
) -> Person:
    """The visitor's own choices; the information class is capped by the role."""
    return _store(
        db,
        person,
        settings,
        rotate=False,
        user_group=user_group,
        info_class=max(1, min(info_class, person.max_info_class)),
        display_name=plain_name(display_name),
    )


def revoke(db: Database, authorities: Sequence[str], actor: str) -> int:
    """Demote every phone authorised by one of ``authorities`` (an account removed or
    its password changed, an address rule deleted); returns how many."""
    with db.session() as session:
        ids = session.scalars(
            select(VisitorRecord.id).where(VisitorRecord.authority.in_(authorities))
        ).all()
        for visitor_id in ids:
            session.execute(
                update(VisitorRecord)
                .where(VisitorRecord.id == visitor_id)
                .values(
                    role="student", authority=None, authorized_role="student", session_id=new_id()
                )
            )
            audit(session, "role_revoked", actor=actor, visitor_id=visitor_id)
    return len(ids)


def remember_person(request: HTTPConnection, person: Person) -> None:
    """Make ``person`` the request's person; a new or rotated session cookie follows."""
    adopt(request, person.visitor)
    request.state.person = person


async def person_of(
    request: HTTPConnection, db: Database, settings: Settings, address: str, rules: AddressRules
) -> Person:
    """The request's person, loaded from its session cookie once per request."""
    known: Person | None = getattr(request.state, "person", None)
    if known is not None:
        return known
    visitor = visitor_of(request, settings.resolved_secret_key)
    person = await db.read(load_person, db, visitor, address, settings, rules.now)
    remember_person(request, person)
    return person


async def person_with(
    request: HTTPConnection,
    db: Database,
    settings: Settings,
    address: str,
    rules: AddressRules,
    function: Callable[P, T],
    *args: P.args,
    **kwargs: P.kwargs,
) -> tuple[Person, T]:
    """The request's person (as :func:`person_of`) and ``function``'s read, in one
    :meth:`~webapp.database.connection.Database.read`: on a database server each read
    is a hand-off to a thread and back, and a scan asked for the class roll and the
    person one after the other (issue 32)."""
    known: Person | None = getattr(request.state, "person", None)
    if known is not None:
        return known, await db.read(function, *args, **kwargs)
    visitor = visitor_of(request, settings.resolved_secret_key)
    read = partial(function, *args, **kwargs)
    person, value = await db.read(_person_and, db, visitor, address, settings, rules, read)
    remember_person(request, person)
    return person, value


def _person_and(
    db: Database,
    visitor: Visitor,
    address: str,
    settings: Settings,
    rules: AddressRules,
    read: Callable[[], T],
) -> tuple[Person, T]:
    return load_person(db, visitor, address, settings, rules.now), read()
