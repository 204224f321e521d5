"""Instructor and admin accounts: argon2 hashes, clear refusals, revocation and audit."""

from __future__ import annotations

import pytest
from sqlalchemy import select

from tests.conftest import TEST_PASSWORD
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import AccountRecord, AuditRecord, VisitorRecord
from webapp.people.accounts import (
    AccountError,
    CampusIdentity,
    add_account,
    authenticate,
    campus_account,
    campus_issuer,
    forget_campus_account,
    list_accounts,
    remove_account,
    set_password,
)
from webapp.people.person import Person, grant, load_person
from webapp.people.visitors import Visitor

HERE = "127.0.0.1"


def phone_of(db: Database, settings: Settings, authority: str) -> Person:
    """A phone made instructor on ``authority``."""
    person = load_person(db, Visitor.fresh(), HERE, settings)
    return grant(db, person, "instructor", authority, settings, HERE)


def role_of(db: Database, person: Person) -> tuple[str, str | None]:
    with db.session() as session:
        record = session.get(VisitorRecord, person.visitor.id)
    assert record is not None
    return record.role, record.authority


def audit_rows(db: Database, action: str) -> list[AuditRecord]:
    with db.session() as session:
        return list(session.scalars(select(AuditRecord).where(AuditRecord.action == action)))


def test_an_added_account_signs_in_with_any_case_of_its_name(db: Database) -> None:
    record = add_account(db, "Ines", "instructor", TEST_PASSWORD, actor="admin")
    assert record.username == "ines" and record.role == "instructor"
    for name in ("ines", "INES", "  Ines "):
        account = authenticate(db, name, TEST_PASSWORD)
        assert account is not None and account.username == "ines"
        assert account.role == "instructor"
    assert [a.username for a in list_accounts(db)] == ["ines"]


def test_a_wrong_password_or_an_unknown_user_is_none(db: Database) -> None:
    add_account(db, "ines", "admin", TEST_PASSWORD, actor="admin")
    assert authenticate(db, "ines", "wrong-password") is None
    assert authenticate(db, "ines", TEST_PASSWORD.upper()) is None
    assert authenticate(db, "ines", "") is None
    assert authenticate(db, "nobody", TEST_PASSWORD) is None
    assert authenticate(db, "", TEST_PASSWORD) is None


def test_only_an_argon2_hash_of_the_password_is_stored(db: Database) -> None:
    add_account(db, "ines", "instructor", TEST_PASSWORD, actor="admin")
    with db.session() as session:
        [record] = session.scalars(select(AccountRecord)).all()
    assert record.password_hash.startswith("$argon2id$")
    assert TEST_PASSWORD not in record.password_hash
    other = add_account(db, "omar", "instructor", TEST_PASSWORD, actor="admin")
    assert other.password_hash != record.password_hash, "salted"


@pytest.mark.parametrize("username", ["a", "", "-ines", ".ines", "in es", "inés", "x" * 64])
def test_invalid_usernames_are_refused(db: Database, username: str) -> None:
    with pytest.raises(AccountError) as error:
        add_account(db, username, "instructor", TEST_PASSWORD, actor="admin")
    assert str(error.value) == (
        f"{username!r} is not a valid username: 2-63 of a-z, 0-9, '.', '_', '-'"
    )
    assert list_accounts(db) == []


def test_usernames_may_use_digits_dots_underscores_and_dashes(db: Database) -> None:
    for name in ("i2", "ines.b", "ines_b", "ines-b", "x" * 63):
        assert add_account(db, name, "instructor", TEST_PASSWORD, actor="admin").username == name


@pytest.mark.parametrize("role", ["student", "superuser", "", "Admin"])
def test_only_instructor_and_admin_accounts_exist(db: Database, role: str) -> None:
    with pytest.raises(AccountError) as error:
        add_account(db, "ines", role, TEST_PASSWORD, actor="admin")
    assert str(error.value) == f"role must be one of instructor, admin, not {role!r}"


def test_short_passwords_are_refused(db: Database) -> None:
    with pytest.raises(AccountError) as error:
        add_account(db, "ines", "instructor", "1234567", actor="admin")
    assert str(error.value) == "a password needs at least 8 characters"
    add_account(db, "ines", "instructor", "12345678", actor="admin")
    with pytest.raises(AccountError, match="at least 8 characters"):
        set_password(db, "ines", "short", actor="admin")
    assert authenticate(db, "ines", "12345678") is not None, "the old password still works"


def test_a_username_is_taken_once_whatever_its_case(db: Database) -> None:
    add_account(db, "ines", "instructor", TEST_PASSWORD, actor="admin")
    for name in ("ines", "INES"):
        with pytest.raises(AccountError) as error:
            add_account(db, name, "admin", TEST_PASSWORD, actor="admin")
        assert str(error.value) == "there is already an account called 'ines'"
    [account] = list_accounts(db)
    assert account.role == "instructor"
    assert len(audit_rows(db, "account_added")) == 1


def test_adding_an_account_is_audited(db: Database) -> None:
    add_account(db, "Ines", "admin", TEST_PASSWORD, actor="operator")
    [entry] = audit_rows(db, "account_added")
    assert entry.actor == "operator"
    assert entry.detail == {"username": "ines", "role": "admin"}


def test_removing_an_account_signs_out_every_phone_it_authorised(
    db: Database, settings: Settings
) -> None:
    add_account(db, "ines", "instructor", TEST_PASSWORD, actor="admin")
    signed_in = phone_of(db, settings, "login:ines")
    paired = phone_of(db, settings, "pairing:ines")
    someone_else = phone_of(db, settings, "login:omar")
    operator = phone_of(db, settings, "operator")
    remove_account(db, " INES ", actor="admin")
    assert role_of(db, signed_in) == ("student", None)
    assert role_of(db, paired) == ("student", None)
    assert role_of(db, someone_else) == ("instructor", "login:omar")
    assert role_of(db, operator) == ("instructor", "operator")
    assert authenticate(db, "ines", TEST_PASSWORD) is None
    assert list_accounts(db) == []
    [entry] = audit_rows(db, "account_removed")
    assert entry.actor == "admin" and entry.detail == {"username": "ines"}
    revoked = audit_rows(db, "role_revoked")
    assert sorted(e.visitor_id for e in revoked) == sorted(
        [signed_in.visitor.id, paired.visitor.id]
    )


def test_removing_an_unknown_account_is_refused(db: Database) -> None:
    with pytest.raises(AccountError) as error:
        remove_account(db, "Nobody", actor="admin")
    assert str(error.value) == "there is no account called 'nobody'"
    assert audit_rows(db, "account_removed") == []


def test_a_new_password_replaces_the_old_and_signs_out_its_phones(
    db: Database, settings: Settings
) -> None:
    add_account(db, "ines", "instructor", TEST_PASSWORD, actor="admin")
    signed_in = phone_of(db, settings, "login:ines")
    paired = phone_of(db, settings, "pairing:ines")
    someone_else = phone_of(db, settings, "login:omar")
    set_password(db, "Ines", "a-brand-new-password", actor="ines")
    assert authenticate(db, "ines", TEST_PASSWORD) is None
    account = authenticate(db, "ines", "a-brand-new-password")
    assert account is not None and account.role == "instructor"
    assert role_of(db, signed_in) == ("student", None)
    assert role_of(db, paired) == ("student", None)
    assert role_of(db, someone_else) == ("instructor", "login:omar")
    [entry] = audit_rows(db, "password_changed")
    assert entry.actor == "ines" and entry.detail == {"username": "ines"}
    with db.session() as session:
        [record] = session.scalars(select(AccountRecord)).all()
    assert record.password_hash.startswith("$argon2id$")
    assert "a-brand-new-password" not in record.password_hash


def test_a_new_password_for_an_unknown_account_is_refused(db: Database) -> None:
    with pytest.raises(AccountError) as error:
        set_password(db, "nobody", TEST_PASSWORD, actor="admin")
    assert str(error.value) == "there is no account called 'nobody'"
    assert audit_rows(db, "password_changed") == []


CAMPUS = "https://login.example.edu"


def person_at(subject: str, hint: str, issuer: str = CAMPUS) -> CampusIdentity:
    return CampusIdentity(issuer=issuer, subject=subject, name_hint=hint, full_name="Zoë Ng")


@pytest.mark.parametrize(
    "hint,username",
    [
        ("Zoë.Ng@example.edu", "zoe.ng"),
        ("jean claude", "jean-claude"),
        ("-_odd__", "odd"),
        ("x", "staff"),
        ("日本", "staff"),
        ("a" * 80, "a" * 56),
    ],
)
def test_a_campus_account_is_named_after_the_providers_name_for_the_person(
    db: Database, hint: str, username: str
) -> None:
    assert campus_account(db, person_at("1", hint), "instructor", "oidc:campus").username == (
        username
    )


def test_a_campus_account_takes_a_name_no_account_has(db: Database) -> None:
    add_account(db, "zoe", "admin", TEST_PASSWORD, actor="admin")
    first = campus_account(db, person_at("1", "zoe@example.edu"), "instructor", "oidc:a")
    second = campus_account(db, person_at("1", "zoe", "https://other.example.org"), "admin", "b")
    assert (first.username, second.username) == ("zoe-2", "zoe-3")
    [entry, *_] = audit_rows(db, "account_added")[1:]
    assert entry.detail == {"username": "zoe-2", "role": "instructor", "issuer": CAMPUS}


def test_a_campus_account_has_no_password(db: Database) -> None:
    campus_account(db, person_at("1", "zoe"), "instructor", "oidc:campus")
    assert authenticate(db, "zoe", "") is None
    with pytest.raises(AccountError, match=f"zoe signs in at {CAMPUS}: it has no password here"):
        set_password(db, "zoe", TEST_PASSWORD, actor="admin")
    assert campus_issuer(db, "zoe") == CAMPUS
    add_account(db, "ines", "instructor", TEST_PASSWORD, actor="admin")
    assert campus_issuer(db, "ines") is None


def test_a_lower_role_at_a_later_sign_in_signs_out_the_accounts_phones(
    db: Database, settings: Settings
) -> None:
    campus_account(db, person_at("1", "zoe"), "instructor", "oidc:campus")
    phone = phone_of(db, settings, "login:zoe")
    campus_account(db, person_at("1", "Zoë Renamed"), "admin", "oidc:campus")
    assert role_of(db, phone) == ("instructor", "login:zoe")  # a higher role takes nothing

    account = campus_account(db, person_at("1", "zoe"), "instructor", "oidc:campus")

    assert (account.username, account.role) == ("zoe", "instructor")
    assert role_of(db, phone) == ("student", None)
    [change, _] = audit_rows(db, "account_role_changed")
    assert change.detail == {"username": "zoe", "role": "admin", "was": "instructor"}


def test_a_campus_account_whose_role_is_gone_is_removed_with_its_phones(
    db: Database, settings: Settings
) -> None:
    campus_account(db, person_at("1", "zoe"), "instructor", "oidc:campus")
    phone = phone_of(db, settings, "login:zoe")

    assert forget_campus_account(db, CAMPUS, "1", "oidc:campus") == "zoe"
    assert forget_campus_account(db, CAMPUS, "1", "oidc:campus") is None

    assert list_accounts(db) == []
    assert role_of(db, phone) == ("student", None)
    [entry] = audit_rows(db, "account_removed")
    assert entry.detail == {"username": "zoe", "reason": "no role"}
