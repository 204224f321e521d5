"""The campus providers' settings: one line per mistake, and how claims map to roles."""

from __future__ import annotations

import json
from typing import Any

import pytest
from pydantic import ValidationError

from webapp.core.oidc import ClaimRule, OIDCProvider, Outcome
from webapp.core.settings import Settings, setting_problems

PROVIDER: dict[str, Any] = {
    "issuer": "https://login.example.edu/realms/staff",
    "client_id": "tagwall",
    "client_secret": "s3cret",
    "name": "Campus account",
    "rules": [{"claim": "groups", "value": "staff", "role": "instructor"}],
}


def problems(**settings: Any) -> list[str]:
    with pytest.raises(ValidationError) as caught:
        Settings(**settings)
    return setting_problems(caught.value, Settings)


def test_providers_come_from_json_and_a_secret_from_a_variable_of_its_own(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    given = {key: value for key, value in PROVIDER.items() if key != "client_secret"}
    monkeypatch.setenv("TAGWALL_OIDC_PROVIDERS", json.dumps({"campus": given}))
    monkeypatch.setenv("TAGWALL_OIDC_PROVIDERS__CAMPUS__CLIENT_SECRET", "from-a-vault")

    provider = Settings().oidc_providers["campus"]

    assert provider.client_secret.get_secret_value() == "from-a-vault"
    assert provider.scopes == ("openid", "email", "profile")
    assert "from-a-vault" not in repr(provider)


def test_each_mistake_is_one_line_naming_the_setting() -> None:
    bad = {
        **PROVIDER,
        "issuer": "http://login.example.edu",
        "client_secret": "",
        "scopes": "email groups",
        "rules": [
            {"claim": "groups", "value": "staff", "role": "student"},
            {"claim": "email", "domain": "not a domain", "role": "instructor"},
            {"claim": "email", "value": "a@b.edu", "domain": "b.edu", "role": "admin"},
            {"claim": "groups", "value": "staff"},
        ],
        "client_secert": "typo",
    }

    assert problems(oidc_providers={"campus": bad, "Big Campus": PROVIDER}) == [
        "TAGWALL_OIDC_PROVIDERS.campus.issuer: 'http://login.example.edu': an issuer is an "
        "https:// URL (http:// on this machine)",
        "TAGWALL_OIDC_PROVIDERS.campus.client_secret: the client secret is empty (the provider "
        "shows it with the client)",
        "TAGWALL_OIDC_PROVIDERS.campus.scopes: the scopes must include openid (without it "
        "there is no ID token)",
        "TAGWALL_OIDC_PROVIDERS.campus.rules.0.role: Input should be 'instructor' or 'admin'",
        "TAGWALL_OIDC_PROVIDERS.campus.rules.1.domain: 'not a domain' is not a mail domain "
        "(example.edu)",
        "TAGWALL_OIDC_PROVIDERS.campus.rules.2: give either value (the claim has it) or "
        "domain (an email at it)",
        "TAGWALL_OIDC_PROVIDERS.campus.rules.3: give what the rule grants: role, user_group "
        "or both",
        "TAGWALL_OIDC_PROVIDERS.campus.client_secert: Extra inputs are not permitted",
        "TAGWALL_OIDC_PROVIDERS.Big Campus.[key]: String should match pattern "
        "'^[a-z0-9][a-z0-9-]{0,31}$'",
    ]


def test_a_provider_needs_a_rule_that_gives_a_role() -> None:
    groups_only = [{"claim": "groups", "value": "med", "user_group": "medical"}]
    assert problems(oidc_providers={"campus": {**PROVIDER, "rules": groups_only}}) == [
        "TAGWALL_OIDC_PROVIDERS.campus.rules: give at least one rule with a role: otherwise "
        "no one can sign in"
    ]


def test_an_issuer_on_this_machine_may_be_http() -> None:
    for issuer in ("http://127.0.0.1:8080", "http://localhost:8080/realms/x", "http://[::1]"):
        assert OIDCProvider.model_validate({**PROVIDER, "issuer": issuer}).issuer == issuer


def test_the_password_form_is_switched_off_only_beside_a_provider() -> None:
    assert problems(password_sign_in=False) == [
        "TAGWALL_PASSWORD_SIGN_IN=false needs an OpenID provider in TAGWALL_OIDC_PROVIDERS: "
        "otherwise no instructor can sign in"
    ]
    assert not Settings(
        password_sign_in=False, oidc_providers={"campus": PROVIDER}
    ).password_sign_in


def test_the_leeway_is_at_most_ten_minutes() -> None:
    assert problems(oidc_leeway_s=601) == [
        "TAGWALL_OIDC_LEEWAY_S: Input should be less than or equal to 600"
    ]


def outcome(rules: list[dict[str, str]], **claims: object) -> Outcome:
    return OIDCProvider.model_validate({**PROVIDER, "rules": rules}).outcome(claims)


RULES = [
    {"claim": "groups", "value": "staff", "role": "instructor"},
    {"claim": "email", "domain": "Faculty.Example.edu", "role": "instructor"},
    {"claim": "preferred_username", "value": "dean", "role": "admin"},
    {"claim": "realm_access.roles", "value": "wall-admin", "role": "admin"},
    {"claim": "groups", "value": "medicine", "user_group": "medical"},
    {"claim": "groups", "value": "research", "user_group": "research"},
]


@pytest.mark.parametrize(
    "claims,expected",
    [
        ({"groups": ["staff"]}, Outcome("instructor", None)),
        ({"groups": "staff"}, Outcome("instructor", None)),  # a string claim is the value
        ({"groups": ["staffroom"]}, Outcome(None, None)),
        ({"email": "ann@faculty.example.EDU"}, Outcome("instructor", None)),
        ({"email": "ann@faculty.example.edu", "email_verified": False}, Outcome(None, None)),
        ({"email": "ann@students.faculty.example.edu"}, Outcome(None, None)),
        ({"preferred_username": "dean", "groups": ["staff"]}, Outcome("admin", None)),
        ({"realm_access": {"roles": ["wall-admin"]}}, Outcome("admin", None)),
        ({"groups": ["staff", "research", "medicine"]}, Outcome("instructor", "medical")),
        ({"groups": ["medicine"]}, Outcome(None, "medical")),
        ({"groups": [True, 1, None]}, Outcome(None, None)),
        ({}, Outcome(None, None)),
    ],
)
def test_the_highest_role_and_the_first_user_group_of_the_matching_rules(
    claims: dict[str, object], expected: Outcome
) -> None:
    assert outcome(RULES, **claims) == expected


def test_a_rule_says_what_it_does() -> None:
    rules = [ClaimRule.model_validate(rule) for rule in RULES]
    assert [rule.describe() for rule in rules[:2]] == [
        "groups has staff: role instructor",
        "email at faculty.example.edu: role instructor",
    ]
    both = {"claim": "groups", "value": "med", "role": "instructor", "user_group": "medical"}
    assert ClaimRule.model_validate(both).describe() == (
        "groups has med: role instructor, user group medical"
    )
