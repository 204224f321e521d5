"""Address rules as the admin manages them: defaults (and, where enabled, the
instructor role) for ranges of phone addresses."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from webapp.core.roles import USER_GROUPS
from webapp.database.connection import Database
from webapp.database.models import AddressRuleRecord
from webapp.people.addresses import parse_network
from webapp.people.audit import audit
from webapp.people.person import plain_text, revoke


class RuleError(ValueError):
    """A rule that cannot be stored; the message says why."""


def list_rules(db: Database) -> list[AddressRuleRecord]:
    with db.session() as session:
        return list(session.scalars(select(AddressRuleRecord).order_by(AddressRuleRecord.network)))


def add_rule(
    db: Database,
    network: str,
    *,
    role: str | None,
    user_group: str | None,
    info_class: int | None,
    note: str,
    actor: str,
) -> AddressRuleRecord:
    try:
        parsed = str(parse_network(network))
    except ValueError as error:
        raise RuleError(str(error)) from None
    if role not in (None, "instructor"):
        raise RuleError("an address rule can grant only the instructor role")
    if user_group is not None and user_group not in USER_GROUPS:
        raise RuleError(f"{user_group!r} is not a user group")
    if info_class is not None and not 1 <= info_class <= 5:
        raise RuleError("the information class is 1 to 5")
    record = AddressRuleRecord(
        network=parsed,
        role=role,
        user_group=user_group,
        info_class=info_class,
        note=plain_text(note)[:200],
    )
    try:
        with db.session() as session:
            session.add(record)
            session.flush()
            audit(session, "rule_added", actor=actor, network=parsed, role=role)
    except IntegrityError:
        raise RuleError(f"there is already a rule for {parsed}") from None
    return record


def remove_rule(db: Database, rule_id: int, actor: str) -> None:
    """Delete the rule; phones it made instructors are students again."""
    with db.session() as session:
        record = session.get(AddressRuleRecord, rule_id)
        if record is None:
            raise RuleError("there is no such rule")
        network = record.network
        session.delete(record)
        audit(session, "rule_removed", actor=actor, network=network)
    revoke(db, [f"address:{network}"], actor)
