"""``tagwall oidc``: what the provider's admin registers, and whether the provider answers."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from tests.conftest import server_port
from tests.oidc.provider import OpenIDProvider
from webapp.cli.commands import main

BASE = "https://wall.example.edu"


def run(tmp_path: Path, **providers: dict[str, object]) -> tuple[int, str]:
    env = {
        "TAGWALL_VAR_DIR": str(tmp_path),
        "TAGWALL_PUBLIC_BASE_URL": BASE,
        "TAGWALL_OIDC_PROVIDERS": json.dumps(providers),
    }
    result = CliRunner().invoke(main, ["oidc"], env=env)
    return result.exit_code, result.stdout


def test_it_prints_what_to_register_and_that_the_provider_answers(
    tmp_path: Path, openid_provider: OpenIDProvider
) -> None:
    client = openid_provider.register(f"{BASE}/login/oidc/campus/callback", f"{BASE}/")

    code, out = run(tmp_path, campus=openid_provider.settings(client))

    assert code == 0, out
    assert out.splitlines() == [
        f"campus: Campus account at {openid_provider.issuer}",
        f"  redirect URI:             {BASE}/login/oidc/campus/callback",
        f"  post-logout redirect URI: {BASE}/",
        f"  client id:                {client.client_id}",
        "  scopes:                   openid email profile groups",
        "  claims the rules read:    groups, email, preferred_username",
        "  rules:                    groups has staff: role instructor",
        "                            email at faculty.example.edu: role instructor",
        "                            preferred_username has dean: role admin",
        "                            groups has medicine: user group medical",
        "  provider:                 answers; its issuer is the one configured",
        f"  its sign-out page:        {openid_provider.issuer}/session/end",
    ]


def test_a_provider_that_does_not_answer_exits_1_saying_why(
    tmp_path: Path, openid_provider: OpenIDProvider
) -> None:
    client = openid_provider.register(f"{BASE}/login/oidc/campus/callback", f"{BASE}/")
    dead = openid_provider.settings(client, issuer=f"http://127.0.0.1:{server_port()}")

    code, out = run(tmp_path, campus=dead)

    assert code == 1
    assert out.splitlines()[-1].startswith("  provider:                 UNAVAILABLE: ConnectError")


def test_without_providers_it_says_where_to_read_on(tmp_path: Path) -> None:
    code, out = run(tmp_path)
    assert code == 0
    assert "no OpenID providers configured (TAGWALL_OIDC_PROVIDERS): see docs/campus.md" in out
