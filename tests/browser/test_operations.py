"""A real `tagwall serve` as an operator runs it: whose address counts, what the log
keeps, and rotating the operator's and the tiles' tokens from the command line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from websockets.sync.client import connect

from tests.browser.conftest import serve
from webapp.cli.testing import ServerProcess, wait_until
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.engine.protocol import CLOSE_POLICY
from webapp.people.address_rules import add_rule
from webapp.people.security import operator_token, tile_token
from webapp.tags.registry import wall_tags


def tagwall(server: ServerProcess, *args: str) -> str:
    """A `tagwall` command with the server's settings; its output."""
    command = [str(Path(sys.executable).with_name("tagwall")), *args]
    done = subprocess.run(command, env=server.env(), capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_forwarded_addresses_are_not_believed_and_tokens_stay_out_of_the_log(
    tmp_path: Path, database_url: str
) -> None:
    upgrade(database_url)
    db = Database(database_url)
    add_rule(
        db,
        "10.9.0.0/16",
        role="instructor",
        user_group=None,
        info_class=None,
        note="",
        actor="test",
    )
    server = serve(tmp_path, database_url, TAGWALL_ADDRESS_RULES_GRANT_ROLES="true")
    try:
        code = next(t.code for t in wall_tags(db, "demo") if t.name == "register-instructor")
        # Without TAGWALL_TRUSTED_PROXIES, a phone on loopback that claims to be 10.9.1.1
        # is sent to sign in: uvicorn's own proxy headers are off.
        forged = httpx.get(
            f"{server.url}/t/{code}", headers={"X-Forwarded-For": "10.9.1.1"}, timeout=10
        )
        assert forged.status_code == 303, forged.text[:300]
        assert forged.headers["location"].startswith("/login")

        tile = tile_token(server.secret, "demo")
        operator = operator_token(server.secret)
        assert httpx.get(server.tile_url("demo", "r1c1"), timeout=10).status_code == 200
        with connect(server.tile_url("demo", "r1c1", scheme="ws")) as socket:
            socket.send('{"type": "hello", "last_version": null}')
            assert '"snapshot"' in str(socket.recv(timeout=10))
        httpx.get(f"{server.url}/login/operator?token={operator}", timeout=10)
        httpx.get(f"{server.url}/login/operator?token=a-wrong-guess", timeout=10)
    finally:
        server.stop()
        db.dispose()
    log = server.log.read_text()
    assert "/wall/demo/tile/r1c1?token=[redacted]" in log, "the tile page's request is logged"
    assert "/login/operator?token=[redacted]" in log
    for secret in (tile, operator, "a-wrong-guess"):
        assert secret not in log


@pytest.mark.persistence
def test_rotating_tokens_closes_old_tiles_and_signs_out_the_old_operator_link(
    tmp_path: Path, database_url: str
) -> None:
    server = serve(tmp_path, database_url)
    try:
        old_tile_url = server.tile_url("demo", "r1c1")
        with httpx.Client(base_url=server.url, timeout=10) as admin:
            admin.get(f"/login/operator?token={operator_token(server.secret)}")
            assert admin.get("/dashboard").status_code == 200
            with connect(server.tile_url("demo", "r1c1", scheme="ws")) as socket:
                socket.send('{"type": "hello", "last_version": null}')
                socket.recv(timeout=10)
                printed = tagwall(server, "tokens", "rotate", "tiles", "--wall", "demo")
                # the open tile is closed within seconds (every process reads the salts)
                while True:
                    try:
                        socket.recv(timeout=30)
                    except Exception:  # the close arrives as ConnectionClosed
                        break
                assert socket.close_code == CLOSE_POLICY
            new_urls = [line.strip() for line in printed.splitlines() if "/tile/" in line]
            assert len(new_urls) == 6 and old_tile_url not in printed
            assert httpx.get(old_tile_url, timeout=10).status_code == 403
            new_r1c1 = next(url for url in new_urls if "/tile/r1c1?" in url)
            assert httpx.get(new_r1c1, timeout=10).status_code == 200

            printed = tagwall(server, "tokens", "rotate", "operator")
            assert "signed out: 1" in printed
            old = {"Authorization": f"Bearer {operator_token(server.secret)}"}
            status = f"{server.url}/api/walls/demo/status"
            wait_until(
                lambda: httpx.get(status, headers=old, timeout=10).status_code == 401,
                what="the server to refuse the old operator token",
            )
            assert admin.get("/dashboard", follow_redirects=False).status_code == 303
            link = printed.split("new operator sign-in link: ")[1].split()[0]
            new_token = link.split("token=")[1]
            new = {"Authorization": f"Bearer {new_token}"}
            assert httpx.get(status, headers=new, timeout=10).status_code == 200
    finally:
        server.stop()
