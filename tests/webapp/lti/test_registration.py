"""Registering a platform (`tagwall lti add`, the admin page), the values an LMS admin
enters, and tagwall's own keys: published, rotated, the old one kept a while."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient
from sqlalchemy import update

from tests.conftest import TEST_SECRET, csrf_of, migrate, services_of, sign_in
from webapp.cli.commands import main
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.database.models import LtiKeyRecord
from webapp.lti.keys import public_key_set, rotate_keys
from webapp.lti.platforms import find_platform, list_platforms

ADD = [
    "lti", "add", "--name", "Canvas", "--issuer", "https://canvas.instructure.com",
    "--client-id", "10000000000042", "--deployment", "7:abc", "--deployment", "8:def",
    "--auth-url", "https://sso.canvaslms.com/api/lti/authorize_redirect",
    "--token-url", "https://canvas.example.edu/login/oauth2/token",
    "--jwks-url", "https://sso.canvaslms.com/api/lti/security/jwks",
]  # fmt: skip


@pytest.fixture
def env(tmp_path: Path, database_url: str) -> dict[str, str]:
    return {
        "TAGWALL_VAR_DIR": str(tmp_path / "var"),
        "TAGWALL_DATABASE_URL": database_url,
        "TAGWALL_SECRET_KEY": TEST_SECRET,
        "TAGWALL_PUBLIC_BASE_URL": "https://wall.example.edu",
        "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls" / "demo.toml"),
    }


def run(env: dict[str, str], *args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args), env=env)
    return result.exit_code, result.stdout + result.stderr


def test_the_cli_registers_lists_and_removes_platforms(
    env: dict[str, str], database_url: str
) -> None:
    code, out = run(env, *ADD)
    assert (code, out) == (0, "platform 1 (Canvas): 2 deployments\n")
    assert run(env, *ADD)[0] == 0  # again: the same registration, updated
    code, out = run(env, "lti", "list")
    assert out.split("\t")[:4] == [
        "1",
        "Canvas",
        "https://canvas.instructure.com",
        "10000000000042",
    ]
    db = Database(database_url)
    try:
        found = find_platform(db, "https://canvas.instructure.com", "10000000000042")
        assert found is not None and found.deployment_ids == ("7:abc", "8:def")
        assert found.origins == ["https://canvas.instructure.com", "https://sso.canvaslms.com"]
    finally:
        db.dispose()
    code, out = run(env, *ADD[:-2], "--jwks-url", "not a url")
    assert code == 2 and "the JWKS URL must be an http(s) URL" in out
    assert run(env, "lti", "remove", "1") == (0, "removed platform 1\n")
    assert run(env, "lti", "remove", "1")[0] == 2


def test_the_values_to_paste(env: dict[str, str]) -> None:
    code, out = run(env, "lti", "values")
    assert code == 0
    assert "login initiation URL: https://wall.example.edu/lti/login" in out
    assert "redirect URI:         https://wall.example.edu/lti/launch" in out
    assert "public keyset URL:    https://wall.example.edu/lti/jwks" in out


def test_a_rotated_key_stays_published_for_the_overlap(
    env: dict[str, str], database_url: str
) -> None:
    migrate(database_url)
    db = Database(database_url)
    try:
        first = public_key_set(db, 24)
        assert len(first) == 1 and "d" not in first[0]  # public halves only
        code, out = run(env, "tokens", "rotate", "lti")
        assert code == 0 and "new LTI signing key" in out
        both = public_key_set(db, 24)
        assert [key["kid"] for key in both][1] == first[0]["kid"]
        with db.session() as session:  # a day and more later
            session.execute(
                update(LtiKeyRecord)
                .where(LtiKeyRecord.kid == first[0]["kid"])
                .values(retired_at=datetime.now(UTC) - timedelta(hours=25))
            )
        assert [key["kid"] for key in public_key_set(db, 24)] == [both[0]["kid"]]
        assert rotate_keys(db, "test") != both[0]["kid"]
    finally:
        db.dispose()


def test_the_admin_page_registers_a_platform(client: TestClient) -> None:
    assert client.get("/dashboard/lti", follow_redirects=False).status_code == 303
    sign_in(client, "admin")
    page = client.get("/dashboard/lti")
    assert "http://192.168.1.20:8000/lti/login" in page.text
    form = {
        "csrf": csrf_of(client, "/dashboard/lti"),
        "name": "Moodle",
        "issuer": "https://moodle.example.edu",
        "client_id": "abc",
        "deployment_ids": "1, 2",
        "auth_url": "https://moodle.example.edu/mod/lti/auth.php",
        "token_url": "https://moodle.example.edu/mod/lti/token.php",
        "jwks_url": "https://moodle.example.edu/mod/lti/certs.php",
    }
    assert client.post("/dashboard/lti", data=form, follow_redirects=False).status_code == 303
    (platform,) = list_platforms(services_of(client).db)
    assert platform.deployment_ids == ("1", "2")
    refused = client.post("/dashboard/lti", data={**form, "deployment_ids": " "})
    assert refused.status_code == 400 and "at least one deployment id" in refused.text
    assert client.get("/lti/jwks").json()["keys"][0]["kty"] == "RSA"
