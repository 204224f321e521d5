"""What `tagwall serve` (`make run`) says at start is true: the codes send phones to an
address the server listens on, or the banner says plainly that phones cannot get in and
how to let them. The process is real; where it listens is read from the kernel's socket
table (this workplace sends test traffic to loopback only, so the LAN address is checked
by the listening socket that covers it rather than by connecting to it)."""

from __future__ import annotations

import ipaddress
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from tests.conftest import TEST_SECRET, server_port
from webapp.cli import commands
from webapp.cli.check import fetch_layout
from webapp.cli.testing import ServerProcess
from webapp.core import settings
from webapp.core.settings import CONTENT_DIR, lan_address
from webapp.people.security import operator_token

LISTEN = "0A"


def listening_on(port: int) -> set[str]:
    """The addresses TCP sockets listen on at ``port``, from /proc/net/tcp{,6}."""
    found = set()
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        lines = Path(table).read_text().splitlines()[1:] if Path(table).exists() else []
        for line in lines:
            fields = line.split()
            address, _, hex_port = fields[1].partition(":")
            if fields[3] != LISTEN or int(hex_port, 16) != port:
                continue
            # the kernel prints each 32-bit word in host (little-endian) order
            words = [bytes.fromhex(address[i : i + 8])[::-1] for i in range(0, width, 8)]
            found.add(str(ipaddress.ip_address(b"".join(words))))
    return found


class DefaultServer(ServerProcess):
    """`tagwall serve` as a newcomer runs it: no host, no public base URL configured."""

    def env(self) -> dict[str, str]:
        environment = super().env()
        for name in ("TAGWALL_HOST", "TAGWALL_PUBLIC_BASE_URL"):
            if name not in self.extra_env:
                environment.pop(name)
        return environment


def banner(server: ServerProcess) -> str:
    """What `serve` printed before serving (the log's lines around it are logging's)."""
    lines = server.log.read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith("tagwall on "))
    rest = lines[first + 1 :]
    end = next((i for i, line in enumerate(rest) if not line.startswith("  ")), len(rest))
    return "\n".join(lines[first : first + 1 + end])


def code_host(text: str) -> str:
    match = re.search(r"codes send them to http://([^:/\s]+):\d+", text)
    assert match, text
    return match.group(1)


def start(server: ServerProcess) -> ServerProcess:
    server.extra_env["TAGWALL_WALL_CONFIGS"] = str(CONTENT_DIR / "walls")
    server.start()
    return server


def student_code(server: ServerProcess) -> str:
    _, layout = fetch_layout(server.url, "demo", operator_token(server.secret))
    return next(code.payload for code in layout.placed if code.label == "Student")


def test_by_default_codes_point_where_the_server_listens_and_the_banner_says_so(
    tmp_path: Path, database_url: str
) -> None:
    server = start(DefaultServer(tmp_path / "var", database_url, TEST_SECRET, server_port()))
    try:
        text = banner(server)
        host = code_host(text)
        assert host == lan_address() != "127.0.0.1", "this machine has a LAN address"
        assert student_code(server).lower().startswith(f"http://{host}:{server.port}/t/")
        listening = listening_on(server.port)
        assert listening & {"0.0.0.0", "::", host}, (host, listening)
        assert "phones on this network" in text
        assert "to keep it on this machine only: TAGWALL_HOST=127.0.0.1" in text
        # the admin link stays on this machine's loopback, never on the network
        assert f"dashboard: http://127.0.0.1:{server.port}/login/operator?token=" in text
    finally:
        server.stop()


def test_kept_on_this_machine_codes_say_so_and_the_banner_says_how_to_let_phones_in(
    tmp_path: Path, database_url: str
) -> None:
    server = DefaultServer(tmp_path / "var", database_url, TEST_SECRET, server_port())
    server.extra_env["TAGWALL_HOST"] = "127.0.0.1"
    start(server)
    try:
        text = banner(server)
        assert code_host(text) == "127.0.0.1"
        assert student_code(server).lower().startswith(f"http://127.0.0.1:{server.port}/t/")
        assert listening_on(server.port) == {"127.0.0.1"}
        assert "phones: cannot reach it" in text
        assert "to let phones in: TAGWALL_HOST=0.0.0.0" in text
    finally:
        server.stop()


def urls(env: dict[str, str]) -> str:
    result = CliRunner().invoke(commands.main, ["urls"], env=env)
    assert result.exit_code == 0, result.output
    return result.stdout


@pytest.fixture
def env(tmp_path: Path, database_url: str) -> dict[str, str]:
    return {
        "TAGWALL_VAR_DIR": str(tmp_path / "var"),
        "TAGWALL_DATABASE_URL": database_url,  # an installation's: `urls` reads its tokens
        "TAGWALL_SECRET_KEY": TEST_SECRET,
        "TAGWALL_PORT": "8111",
        "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
    }


def test_without_a_network_the_banner_says_phones_cannot_reach_it(
    env: dict[str, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(settings, "lan_address", lambda: "127.0.0.1")
    monkeypatch.setattr(commands, "lan_address", lambda: "127.0.0.1")
    text = urls(env)
    assert "this machine has no network address" in text
    assert "codes send them to http://127.0.0.1:8111" in text


def test_a_configured_public_address_is_named_as_such(env: dict[str, str]) -> None:
    text = urls({**env, "TAGWALL_PUBLIC_BASE_URL": "https://wall.example.org/"})
    assert "codes send them to https://wall.example.org (TAGWALL_PUBLIC_BASE_URL)" in text
    assert "listening on every network interface, port 8111" in text
