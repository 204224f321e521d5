"""The campus's OpenID providers as an installation configures them
(``TAGWALL_OIDC_PROVIDERS``): each provider's shape, validated with the settings, and
the rules that turn the claims of a signed-in person into a tagwall role and user group.

Pure data and rules, no network: the sign-in itself is :mod:`webapp.campus.oidc`.
"""

from __future__ import annotations

import ipaddress
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Annotated, Literal
from urllib.parse import urlsplit

from pydantic import BaseModel, ConfigDict, Field, SecretStr, field_validator, model_validator

from webapp.core.roles import ROLES, UserGroup

ProviderName = Annotated[str, Field(pattern=r"^[a-z0-9][a-z0-9-]{0,31}$")]
"""A provider's key: in its sign-in URLs (``/login/oidc/<name>``), so short and plain."""
AccountRole = Literal["instructor", "admin"]
"""What a provider's rules may make someone: staff sign in, students scan codes."""
DEFAULT_SCOPES = ("openid", "email", "profile")
_SCOPE = re.compile(r"^[\x21\x23-\x5b\x5d-\x7e]+$")  # RFC 6749 3.3
_LOOPBACK_NAMES = ("localhost",)


def _on_this_machine(host: str) -> bool:
    if host in _LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def claim_of(claims: Mapping[str, object], name: str) -> object:
    """The claim ``name``: as it stands, else a path into nested claims (Keycloak's
    ``realm_access.roles``); None when there is none."""
    if name in claims:
        return claims[name]
    found: object = claims
    for part in name.split("."):
        if not isinstance(found, Mapping) or part not in found:
            return None
        found = found[part]
    return found


class ClaimRule(BaseModel):
    """One line of a provider's mapping: when the claim ``claim`` has ``value`` (a
    string claim is it, a list claim holds it) or is an email address at ``domain``,
    the person gets ``role``, ``user_group``, or both."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    claim: str = Field(min_length=1, max_length=200)
    value: str | None = Field(default=None, min_length=1, max_length=500)
    domain: str | None = Field(default=None, min_length=1, max_length=253)
    role: AccountRole | None = None
    user_group: UserGroup | None = None

    @field_validator("domain", mode="after")
    @classmethod
    def _a_bare_domain(cls, value: str | None) -> str | None:
        if value is None:
            return value
        domain = value.strip().lower().removeprefix("@")
        if "@" in domain or "." not in domain or " " in domain:
            raise ValueError(f"{value!r} is not a mail domain (example.edu)")
        return domain

    @model_validator(mode="after")
    def _one_test_and_an_outcome(self) -> ClaimRule:
        if (self.value is None) == (self.domain is None):
            raise ValueError("give either value (the claim has it) or domain (an email at it)")
        if self.role is None and self.user_group is None:
            raise ValueError("give what the rule grants: role, user_group or both")
        return self

    def matches(self, claims: Mapping[str, object]) -> bool:
        found = claim_of(claims, self.claim)
        values = found if isinstance(found, list) else [found]
        strings = [str(v) for v in values if isinstance(v, str | int) and not isinstance(v, bool)]
        if self.value is not None:
            return self.value in strings
        # An address the provider says it has not verified proves no domain.
        if self.claim == "email" and claims.get("email_verified") is False:
            return False
        return any(s.rpartition("@")[2].lower() == self.domain for s in strings if "@" in s)

    def describe(self) -> str:
        """The rule as the refusal page and ``tagwall oidc`` say it."""
        test = f"{self.claim} has {self.value}" if self.value else f"{self.claim} at {self.domain}"
        grants = [f"role {self.role}"] if self.role else []
        if self.user_group:
            grants.append(f"user group {self.user_group}")
        return f"{test}: {', '.join(grants)}"


@dataclass(frozen=True)
class Outcome:
    """What a provider's rules make of a person's claims."""

    role: AccountRole | None
    user_group: UserGroup | None


class OIDCProvider(BaseModel):
    """One OpenID provider: where it is, tagwall's client there, what to ask for and
    how its claims map to roles and user groups."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    issuer: str = Field(min_length=1, max_length=500)
    client_id: str = Field(min_length=1, max_length=500)
    client_secret: SecretStr
    name: str = Field(min_length=1, max_length=60)
    scopes: tuple[str, ...] = DEFAULT_SCOPES
    rules: tuple[ClaimRule, ...]
    end_session_url: str = Field(default="", max_length=2_000)

    @field_validator("issuer", mode="after")
    @classmethod
    def _an_issuer(cls, value: str) -> str:
        """An https URL (OpenID Connect Discovery 1.0, 3), or http on this machine to
        try a provider out."""
        parts = urlsplit(value)
        local = parts.scheme == "http" and _on_this_machine(parts.hostname or "")
        if parts.scheme != "https" and not local:
            raise ValueError(f"{value!r}: an issuer is an https:// URL (http:// on this machine)")
        if parts.query or parts.fragment or not parts.hostname:
            raise ValueError(f"{value!r} is not an issuer URL (no query or fragment)")
        return value

    @field_validator("client_secret", mode="after")
    @classmethod
    def _a_secret(cls, value: SecretStr) -> SecretStr:
        if not value.get_secret_value():
            raise ValueError("the client secret is empty (the provider shows it with the client)")
        return value

    @field_validator("rules", mode="after")
    @classmethod
    def _some_rule(cls, value: tuple[ClaimRule, ...]) -> tuple[ClaimRule, ...]:
        """Checked once every rule is valid, so a bad rule is one line, not two."""
        if not any(rule.role for rule in value):
            raise ValueError("give at least one rule with a role: otherwise no one can sign in")
        return value

    @field_validator("end_session_url", mode="after")
    @classmethod
    def _a_page(cls, value: str) -> str:
        if value and urlsplit(value).scheme not in ("https", "http"):
            raise ValueError(f"{value!r} is not an http:// or https:// URL")
        return value

    @field_validator("scopes", mode="before")
    @classmethod
    def _split_scopes(cls, value: object) -> object:
        """``"openid email groups"`` as well as a list, as OAuth writes scopes."""
        return value.split() if isinstance(value, str) else value

    @field_validator("scopes", mode="after")
    @classmethod
    def _openid_first(cls, value: tuple[str, ...]) -> tuple[str, ...]:
        bad = [scope for scope in value if not _SCOPE.match(scope)]
        if bad:
            raise ValueError(f"{bad[0]!r} is not a scope")
        if "openid" not in value:
            raise ValueError("the scopes must include openid (without it there is no ID token)")
        return value

    def outcome(self, claims: Mapping[str, object]) -> Outcome:
        """The highest role any matching rule gives (none: no role) and the user
        group of the first matching rule that names one."""
        matching = [rule for rule in self.rules if rule.matches(claims)]
        roles = [rule.role for rule in matching if rule.role]
        groups = [rule.user_group for rule in matching if rule.user_group]
        return Outcome(
            role=max(roles, key=ROLES.index) if roles else None,
            user_group=groups[0] if groups else None,
        )

    @property
    def claims_read(self) -> list[str]:
        """The claims the rules read, each once, in the rules' order."""
        return list(dict.fromkeys(rule.claim for rule in self.rules))
