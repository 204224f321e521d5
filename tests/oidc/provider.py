"""The test OpenID Provider, as the tests use it: ``provider.mjs`` (oidc-provider from
npm, which ``npm ci`` installs) run by node, configured here, behind a :class:`Cable` a
test may cut.

Each test registers a client of its own (the provider's dynamic registration, with its
server's redirect URI) and signs in on the provider's own login page: through httpx
(:meth:`OpenIDProvider.sign_in`) or in Chromium. ``ACCOUNTS`` can sign in from the start;
a test adds others with claims of its own. Forged and wrong ID tokens are made here with
joserfc, signed with the provider's own key (right signature, wrong claims) or with a key
it does not have, and handed out by the provider in a client's next token response.
"""

from __future__ import annotations

import json
import secrets
import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

import httpx
import pytest
from joserfc import jwt
from joserfc.jwk import RSAKey

from tests.cable import Cable
from webapp.cli.testing import wait_until

SCRIPT = Path(__file__).with_name("provider.mjs")
PROVIDER_MODULE = Path(__file__).parents[2] / "node_modules" / "oidc-provider"
ACCOUNTS: dict[str, dict[str, Any]] = {
    "sam": {
        "name": "Sam Staff",
        "preferred_username": "sam",
        "email": "sam@staff.example.edu",
        "email_verified": True,
        "groups": ["staff", "medicine"],
    },
    "vic": {
        "name": "Vic Visitor",
        "preferred_username": "vic",
        "email": "vic@elsewhere.example.org",
        "email_verified": True,
        "groups": ["guests"],
    },
}
"""Who can sign in from the start: ``sam`` on the staff, ``vic`` whom no rule gives a role."""
RULES: list[dict[str, str]] = [
    {"claim": "groups", "value": "staff", "role": "instructor"},
    {"claim": "email", "domain": "faculty.example.edu", "role": "instructor"},
    {"claim": "preferred_username", "value": "dean", "role": "admin"},
    {"claim": "groups", "value": "medicine", "user_group": "medical"},
]
"""The mapping the tests configure: a group, a mail domain, one named account."""


@dataclass(frozen=True)
class Client:
    """A client registered at the provider: what tagwall's settings name."""

    client_id: str
    client_secret: str


class OpenIDProvider:
    """The running test provider: its issuer (through the cable), its signing key, and
    what a test asks of it."""

    def __init__(self, issuer: str, key: RSAKey, cable: Cable) -> None:
        self.issuer = issuer
        self.key = key
        self.cable = cable
        self.http = httpx.Client(base_url=issuer, timeout=10)

    def register(self, redirect_uri: str, post_logout_uri: str) -> Client:
        """A new client for a test's server (dynamic client registration)."""
        response = self.http.post(
            "/reg",
            json={
                "redirect_uris": [redirect_uri],
                "post_logout_redirect_uris": [post_logout_uri],
                "client_name": "tagwall under test",
            },
        )
        response.raise_for_status()
        body = response.json()
        return Client(body["client_id"], body["client_secret"])

    def settings(self, client: Client, **changes: Any) -> dict[str, Any]:
        """The ``TAGWALL_OIDC_PROVIDERS`` entry of ``client`` (with ``changes``)."""
        return {
            "issuer": self.issuer,
            "client_id": client.client_id,
            "client_secret": client.client_secret,
            "name": "Campus account",
            "scopes": ["openid", "email", "profile", "groups"],
            "rules": RULES,
            **changes,
        }

    def add_account(self, login: str, claims: dict[str, Any]) -> None:
        self.http.post("/test/accounts", json={"login": login, "claims": claims}).raise_for_status()

    @contextmanager
    def clock_off(self, seconds: int) -> Iterator[None]:
        """The provider's clock ``seconds`` ahead of this machine's (behind if negative)."""
        self.http.post("/test/clock", json={"skew_s": seconds}).raise_for_status()
        try:
            yield
        finally:
            self.http.post("/test/clock", json={"skew_s": 0}).raise_for_status()

    def hand_out(self, client: Client, id_token: str) -> None:
        """The provider's next token response to ``client`` carries ``id_token``."""
        body = {"client_id": client.client_id, "id_token": id_token}
        self.http.post("/test/id-token", json=body).raise_for_status()

    def id_token(
        self,
        client: Client,
        nonce: str,
        key: RSAKey | None = None,
        kid: str | None = None,
        omit: tuple[str, ...] = (),
        **claims: Any,
    ) -> str:
        """An ID token for ``sam`` as the provider would sign it (with ``key``: one it
        does not have, named ``kid``), its claims changed by ``claims`` and without
        ``omit``."""
        now = int(time.time())
        payload = {
            "iss": self.issuer,
            "sub": "sam",
            "aud": client.client_id,
            "iat": now,
            "exp": now + 600,
            "nonce": nonce,
            **ACCOUNTS["sam"],
            **claims,
        }
        for name in omit:
            payload.pop(name)
        signer = key or self.key
        return jwt.encode({"alg": "RS256", "kid": kid or signer.kid}, payload, signer)

    def sign_in(self, authorization_url: str, login: str) -> str:
        """Sign ``login`` in on the provider's own login page (any password) for the
        authorization request ``authorization_url``; where the provider sends the
        browser back (the tagwall server's redirect URI, with the code)."""
        with httpx.Client(timeout=10) as browser:
            response = browser.get(authorization_url)
            for _ in range(5):
                location = str(response.url.join(response.headers.get("location", "")))
                if not location.startswith(self.issuer):
                    return location
                if "/interaction/" in location:
                    form = {"prompt": "login", "login": login, "password": "any"}
                    response = browser.post(location, data=form)
                else:
                    response = browser.get(location)
        raise AssertionError(f"the provider did not send the browser back: {response.text}")


def nonce_of(authorization_url: str) -> str:
    """The nonce tagwall sent in an authorization request."""
    return parse_qs(urlsplit(authorization_url).query)["nonce"][0]


@contextmanager
def running_provider(folder: Path, port: int) -> Iterator[OpenIDProvider]:
    """The test provider listening on ``port``, reached through a cable, for as long as
    the block runs; its output in ``folder``/provider.log."""
    node = shutil.which("node")
    if node is None or not PROVIDER_MODULE.is_dir():
        pytest.fail("node or oidc-provider is missing: run `make test` (npm ci installs it)")
    cable = Cable(f"http://127.0.0.1:{port}")
    key = RSAKey.generate_key(
        2048, parameters={"kid": "test-op", "use": "sig", "alg": "RS256"}, private=True
    )
    config = {
        "issuer": cable.url,
        "port": port,
        "signing_key": key.as_dict(private=True),
        "cookie_key": secrets.token_urlsafe(32),
        "accounts": ACCOUNTS,
    }
    (folder / "provider.json").write_text(json.dumps(config))
    log = folder / "provider.log"
    with log.open("ab") as output:
        process = subprocess.Popen(
            [node, str(SCRIPT), str(folder / "provider.json")],
            stdout=output,
            stderr=subprocess.STDOUT,
        )
    provider = OpenIDProvider(cable.url, key, cable)
    try:
        wait_until(
            lambda: _answers(provider, process, log),
            what=f"the test OpenID Provider to start (log: {log})",
            timeout=60,
        )
        yield provider
    finally:
        provider.http.close()
        process.terminate()
        process.wait(timeout=10)
        cable.close()


def _answers(provider: OpenIDProvider, process: subprocess.Popen[bytes], log: Path) -> bool:
    if process.poll() is not None:
        raise RuntimeError(f"the test OpenID Provider exited:\n{log.read_text()[-3000:]}")
    try:
        return provider.http.get("/.well-known/openid-configuration").status_code == 200
    except httpx.HTTPError:
        return False
