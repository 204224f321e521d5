"""People: roles, authority, profiles and address defaults, and how each one changes."""

from __future__ import annotations

from dataclasses import replace

import pytest
from sqlalchemy import event, select

from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import AddressRuleRecord, AuditRecord, VisitorRecord
from webapp.people.person import (
    MAX_DISPLAY_NAME,
    Person,
    address_grant,
    assume,
    grant,
    load_person,
    plain_name,
    revoke,
    sign_out,
    update_profile,
)
from webapp.people.visitors import Visitor

HERE = "127.0.0.1"


def newcomer(db: Database, settings: Settings, address: str = HERE) -> Person:
    return load_person(db, Visitor.fresh(), address, settings)


def instructor(db: Database, settings: Settings, authority: str = "login:ines") -> Person:
    return grant(db, newcomer(db, settings), "instructor", authority, settings, HERE)


def add_rule(db: Database, network: str, **fields: object) -> None:
    values: dict[str, object] = {"role": None, "user_group": None, "info_class": None}
    with db.session() as session:
        session.add(AddressRuleRecord(network=network, note="", **{**values, **fields}))


def audit_rows(db: Database, action: str) -> list[AuditRecord]:
    with db.session() as session:
        return list(
            session.scalars(
                select(AuditRecord).where(AuditRecord.action == action).order_by(AuditRecord.id)
            )
        )


def visitor_row(db: Database, visitor_id: str) -> VisitorRecord:
    with db.session() as session:
        record = session.get(VisitorRecord, visitor_id)
    assert record is not None
    return record


def test_a_new_visitor_is_an_unstored_student_with_the_defaults(
    db: Database, settings: Settings
) -> None:
    visitor = Visitor.fresh()
    person = load_person(db, visitor, HERE, settings)
    assert person.visitor == visitor
    assert person.role == "student" and person.authorized_role == "student"
    assert person.authority is None
    assert not person.stored
    assert person.user_group == settings.default_user_group
    assert person.info_class == settings.info_class_default["student"]
    assert person.max_info_class == settings.info_class_max["student"] == 3
    assert person.display_name == "" and person.public_name == "a student"
    assert not person.is_staff
    with db.session() as session:
        assert session.scalars(select(VisitorRecord)).all() == [], "loading stores nothing"


def test_assuming_student_stores_the_visitor(db: Database, settings: Settings) -> None:
    visitor = Visitor.fresh()
    stored = assume(db, load_person(db, visitor, HERE, settings), "student", settings, HERE)
    assert stored.stored and stored.role == "student"
    assert stored.visitor.id == visitor.id
    assert stored.visitor.session_id == visitor.session_id, "no privilege changed"
    again = load_person(db, visitor, HERE, settings)
    assert again.stored and again.visitor.id == visitor.id
    assert assume(db, again, "student", settings, HERE) is again, "nothing to do"


def test_a_registration_writes_the_row_and_reads_it_back_in_one_statement(
    db: Database, settings: Settings
) -> None:
    """Every phone of a room registers: its row is written by a statement built once
    that returns the row, so the write is not followed by a read of it."""
    statements: list[str] = []

    def executed(_conn: object, _cursor: object, statement: str, *_: object) -> None:
        statements.append(" ".join(statement.split()[:3]).upper())

    event.listen(db.engine, "before_cursor_execute", executed)
    try:
        first = assume(db, newcomer(db, settings), "student", settings, HERE)
        statements.clear()
        assume(db, newcomer(db, settings), "student", settings, HERE)
        registered = list(statements)
        statements.clear()
        changed = update_profile(
            db, first, settings, user_group="medical", info_class=2, display_name="Ann"
        )
    finally:
        event.remove(db.engine, "before_cursor_execute", executed)
    # the SELECTs: the newcomer's row (none yet) and the address rules, then the write
    # (the INSERT alone: a visitor this request made has an id no row holds) and the
    # rules the person is made with
    assert registered == [
        "SELECT VISITORS.ID, VISITORS.SESSION_ID,",
        "SELECT ADDRESS_RULES.ID, ADDRESS_RULES.NETWORK,",
        "INSERT INTO VISITORS",
        "SELECT ADDRESS_RULES.ID, ADDRESS_RULES.NETWORK,",
    ]
    assert statements == ["UPDATE VISITORS SET", "SELECT ADDRESS_RULES.ID, ADDRESS_RULES.NETWORK,"]
    assert changed.display_name == "Ann" and changed.user_group == "medical"
    assert load_person(db, first.visitor, HERE, settings) == changed


def test_a_cookie_without_a_row_is_stored_by_an_update_or_an_insert(
    db: Database, settings: Settings
) -> None:
    """A phone that brought a cookie may have its row already (written by another of its
    requests meanwhile): its write tries the UPDATE first and never fails on the key."""
    brought = replace(Visitor.fresh(), brought_cookie=True)
    first = load_person(db, brought, HERE, settings)
    second = load_person(db, brought, HERE, settings)
    assert not first.stored and not second.stored
    assume(db, first, "student", settings, HERE)
    stored = update_profile(
        db, second, settings, user_group="medical", info_class=2, display_name=""
    )
    assert stored.stored and stored.user_group == "medical"
    assert visitor_row(db, brought.id).user_group == "medical"


def test_grant_rotates_the_session_and_is_audited(db: Database, settings: Settings) -> None:
    person = newcomer(db, settings)
    granted = grant(db, person, "instructor", "login:ines", settings, "10.0.0.5")
    assert granted.visitor.id == person.visitor.id
    assert granted.visitor.session_id != person.visitor.session_id
    assert granted.visitor.changed
    assert granted.role == "instructor" and granted.authorized_role == "instructor"
    assert granted.authority == "login:ines"
    assert granted.is_staff and granted.stored
    assert granted.max_info_class == settings.info_class_max["instructor"]
    [entry] = audit_rows(db, "role_granted")
    assert entry.visitor_id == person.visitor.id
    assert entry.actor == "login:ines"
    assert entry.client_address == "10.0.0.5"
    assert entry.detail == {
        "role": "instructor",
        "authority": "login:ines",
        "authorized_role": "instructor",
    }
    loaded = load_person(db, granted.visitor, HERE, settings)
    assert loaded.role == "instructor" and loaded.authority == "login:ines"


def test_a_cookie_from_before_a_rotation_is_a_new_anonymous_visitor(
    db: Database, settings: Settings
) -> None:
    person = newcomer(db, settings)
    granted = grant(db, person, "instructor", "login:ines", settings, HERE)
    copied = load_person(db, person.visitor, HERE, settings)
    assert copied.visitor.id != person.visitor.id
    assert copied.visitor.session_id != granted.visitor.session_id
    assert copied.role == "student" and copied.authority is None and not copied.stored
    assert load_person(db, granted.visitor, HERE, settings).role == "instructor"


def test_assuming_a_role_beyond_the_authority_is_refused(db: Database, settings: Settings) -> None:
    person = newcomer(db, settings)
    for role in ("instructor", "admin"):
        with pytest.raises(PermissionError):
            assume(db, person, role, settings, HERE)
    stored = assume(db, person, "student", settings, HERE)
    with pytest.raises(PermissionError):
        assume(db, stored, "instructor", settings, HERE)
    with pytest.raises(PermissionError):
        assume(db, instructor(db, settings), "admin", settings, HERE)


def test_stepping_down_and_up_again_needs_no_new_grant(db: Database, settings: Settings) -> None:
    granted = instructor(db, settings)
    student = assume(db, granted, "student", settings, HERE)
    assert student.role == "student"
    assert student.authorized_role == "instructor" and student.authority == "login:ines"
    assert student.visitor.session_id != granted.visitor.session_id
    reloaded = load_person(db, student.visitor, HERE, settings)
    assert reloaded.role == "student" and reloaded.may_assume("instructor")
    back = assume(db, reloaded, "instructor", settings, HERE)
    assert back.role == "instructor"
    assert back.visitor.id == granted.visitor.id
    assert back.visitor.session_id != student.visitor.session_id
    assert [e.detail["role"] for e in audit_rows(db, "role_changed")] == ["student", "instructor"]


def test_sign_out_drops_the_role_and_the_authority(db: Database, settings: Settings) -> None:
    granted = instructor(db, settings)
    out = sign_out(db, granted, settings, HERE)
    assert out.role == "student" and out.authorized_role == "student"
    assert out.authority is None
    assert out.visitor.id != granted.visitor.id  # a new visitor: nothing of the last one
    assert not out.stored and out.display_name == ""
    with pytest.raises(PermissionError):
        assume(db, out, "instructor", settings, HERE)
    assert len(audit_rows(db, "logout")) == 1
    assert load_person(db, granted.visitor, HERE, settings).visitor.id != granted.visitor.id


def test_the_profile_is_stored_and_capped_by_the_role(db: Database, settings: Settings) -> None:
    person = newcomer(db, settings)
    updated = update_profile(
        db, person, settings, user_group="k5", info_class=5, display_name="  " + "x" * 100 + "  "
    )
    assert updated.user_group == "k5"
    assert updated.info_class == 3, "a student's maximum"
    assert updated.display_name == "x" * 40
    assert updated.visitor == person.visitor, "no privilege changed: no rotation"
    loaded = load_person(db, person.visitor, HERE, settings)
    assert (loaded.user_group, loaded.info_class, loaded.display_name) == ("k5", 3, "x" * 40)
    assert loaded.public_name == "x" * 40 + " (student)"
    low = update_profile(db, loaded, settings, user_group="k5", info_class=0, display_name=" Ann ")
    assert low.info_class == 1 and low.display_name == "Ann"
    staff = update_profile(
        db, instructor(db, settings), settings, user_group="research", info_class=5, display_name=""
    )
    assert staff.info_class == 5


def test_the_role_maximum_comes_from_the_settings(db: Database, settings: Settings) -> None:
    strict = settings.model_copy(
        update={"info_class_max": {"student": 2, "instructor": 5, "admin": 5}}
    )
    person = newcomer(db, strict)
    assert person.max_info_class == 2
    updated = update_profile(db, person, strict, user_group="k5", info_class=3, display_name="")
    assert updated.info_class == 2


def test_an_address_rule_gives_defaults_but_the_visitors_choice_wins(
    db: Database, settings: Settings
) -> None:
    add_rule(db, "10.9.0.0/16", user_group="medical", info_class=2)
    inside = newcomer(db, settings, "10.9.1.2")
    assert (inside.user_group, inside.info_class) == ("medical", 2)
    outside = newcomer(db, settings, "192.168.1.1")
    assert outside.user_group == settings.default_user_group
    assert outside.info_class == settings.info_class_default["student"]
    # a stored visitor who chose nothing still gets the rule's defaults
    stored = assume(db, inside, "student", settings, "10.9.1.2")
    assert (stored.user_group, stored.info_class) == ("medical", 2)
    chosen = update_profile(db, stored, settings, user_group="k5", info_class=1, display_name="")
    loaded = load_person(db, chosen.visitor, "10.9.1.2", settings)
    assert (loaded.user_group, loaded.info_class) == ("k5", 1)


def test_a_rule_cannot_lift_the_information_class_over_the_role_maximum(
    db: Database, settings: Settings
) -> None:
    add_rule(db, "10.9.0.0/16", info_class=5)
    assert newcomer(db, settings, "10.9.1.2").info_class == 3


def test_address_grants_need_the_setting(db: Database, settings: Settings) -> None:
    add_rule(db, "10.9.0.0/16", role="instructor")
    assert not settings.address_rules_grant_roles
    assert address_grant(db, "10.9.1.2", settings) is None
    enabled = settings.model_copy(update={"address_rules_grant_roles": True})
    assert address_grant(db, "10.9.1.2", enabled) == "address:10.9.0.0/16"
    assert address_grant(db, "192.168.1.1", enabled) is None
    assert address_grant(db, "testclient", enabled) is None


def test_a_rule_without_a_role_grants_nothing(db: Database, settings: Settings) -> None:
    add_rule(db, "10.9.0.0/16", user_group="k5")
    enabled = settings.model_copy(update={"address_rules_grant_roles": True})
    assert address_grant(db, "10.9.1.2", enabled) is None


def test_revoke_demotes_every_phone_of_an_authority(db: Database, settings: Settings) -> None:
    first = instructor(db, settings, "login:ines")
    second = instructor(db, settings, "login:ines")
    other = instructor(db, settings, "login:omar")
    assert revoke(db, ["login:ines", "pairing:ines"], actor="admin") == 2
    for person in (first, second):
        record = visitor_row(db, person.visitor.id)
        assert (record.role, record.authority, record.authorized_role) == (
            "student",
            None,
            "student",
        )
        assert record.session_id != person.visitor.session_id, "the session was rotated"
        reloaded = load_person(db, person.visitor, HERE, settings)
        assert reloaded.visitor.id != person.visitor.id and reloaded.role == "student"
    assert load_person(db, other.visitor, HERE, settings).role == "instructor"
    entries = audit_rows(db, "role_revoked")
    assert sorted(e.visitor_id for e in entries) == sorted([first.visitor.id, second.visitor.id])
    assert {e.actor for e in entries} == {"admin"}
    assert revoke(db, ["login:nobody"], actor="admin") == 0


@pytest.mark.parametrize(
    "typed,kept",
    [
        ("  Ann  ", "Ann"),
        ("\u202eThe Dean\u200b", "The Dean"),  # a bidi override and a zero-width space
        ("Ann\n\n(instructor)\tsays", "Ann (instructor) says"),
        ("\uff24\uff45\uff41\uff4e", "Dean"),  # fullwidth letters folded
        ("a" * 100, "a" * MAX_DISPLAY_NAME),
        ("\x00\x07\u2066", ""),
    ],
)
def test_display_names_are_plain_and_short(typed: str, kept: str) -> None:
    assert plain_name(typed) == kept


def test_the_public_screen_names_someone_nameless_with_the_right_article(
    db: Database, settings: Settings
) -> None:
    student = newcomer(db, settings)
    teacher = instructor(db, settings)
    admin = grant(db, newcomer(db, settings), "admin", "login:ada", settings, HERE)
    assert [p.public_name for p in (student, teacher, admin)] == [
        "a student",
        "an instructor",
        "an administrator",
    ]
    named = update_profile(
        db, teacher, settings, user_group="k5", info_class=1, display_name="Ines"
    )
    assert named.public_name == "Ines (instructor)"
