"""A real ``tagwall serve`` process for browser tests and benchmarks.

Both need what an operator has: a server they can start, stop and start again on
the same port and database, and the operator API to change a wall.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

from webapp.people.security import operator_token, tile_token
from webapp.web.urls import tile_path


def free_port() -> int:
    """A TCP port nobody listens on right now."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def wait_until(condition: Callable[[], object], timeout: float = 20.0, what: str = "it") -> None:
    """Poll ``condition`` until it is true: a loaded machine is slow, not wrong."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise TimeoutError(f"timed out after {timeout:.0f} s waiting for {what}")


@dataclass
class ServerProcess:
    """``tagwall serve`` on 127.0.0.1 with its own var dir, database and secret."""

    var_dir: Path
    database_url: str
    secret: str
    port: int = field(default_factory=free_port)
    extra_env: dict[str, str] = field(default_factory=dict)
    command: list[str] | None = None  # default: `tagwall serve`
    process: subprocess.Popen[bytes] | None = None
    _http: httpx.Client | None = field(default=None, init=False, repr=False)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    @property
    def http(self) -> httpx.Client:
        """One client while the server runs: a new client loads the CA bundle (about
        10 ms of CPU), and tests poll the server many times a second. A connection per
        request still, as with a client each: a test may kill one of the server's
        worker processes, and a kept connection would go with it."""
        if self._http is None:
            self._http = httpx.Client(
                base_url=self.url, timeout=10, limits=httpx.Limits(max_keepalive_connections=0)
            )
        return self._http

    @property
    def log(self) -> Path:
        return self.var_dir / "server.log"

    @property
    def pid(self) -> int:
        assert self.process is not None, "the server is not running"
        return self.process.pid

    def env(self) -> dict[str, str]:
        return {
            **os.environ,
            "TAGWALL_VAR_DIR": str(self.var_dir),
            "TAGWALL_DATABASE_URL": self.database_url,
            "TAGWALL_SECRET_KEY": self.secret,
            "TAGWALL_HOST": "127.0.0.1",
            "TAGWALL_PORT": str(self.port),
            "TAGWALL_PUBLIC_BASE_URL": self.url,
            **self.extra_env,
        }

    def start(self) -> None:
        self.var_dir.mkdir(parents=True, exist_ok=True)
        tagwall = Path(sys.executable).with_name("tagwall")
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                self.command or [str(tagwall), "serve"],
                env=self.env(),
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        # A server that fails exits (``healthy`` raises), so a long bound costs nothing;
        # startup imports and places every wall's codes, 40 s on a loaded 2-core machine.
        wait_until(self.healthy, timeout=120, what=f"the server to answer (log: {self.log})")

    def healthy(self) -> bool:
        assert self.process is not None
        if self.process.poll() is not None:
            raise RuntimeError(f"the server exited:\n{self.log.read_text()[-3000:]}")
        try:
            return self.http.get("/healthz", timeout=1).status_code == 200
        except httpx.HTTPError:
            return False

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.process = None
        if self._http is not None:
            self._http.close()
            self._http = None

    def tile_url(self, wall: str, tile: str, *, scheme: str = "http") -> str:
        base = self.url.replace("http", scheme, 1) + ("/ws" if scheme == "ws" else "")
        return base + tile_path(tile_token(self.secret, wall), wall, tile)

    def operator(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {operator_token(self.secret)}"}

    def change(self, wall: str, patch: dict[str, Any], client: httpx.Client | None = None) -> int:
        """Change a wall's state as the operator does; returns the new version."""
        post = (client or self.http).post
        # a heavy change (the census map's first import, placing codes) takes seconds
        # on a loaded machine: slow, not wrong
        response = post(
            f"{self.url}/api/walls/{wall}/state", json=patch, headers=self.operator(), timeout=60
        )
        if response.is_error:
            raise RuntimeError(f"{patch} answered {response.status_code}: {response.text}")
        return int(response.json()["version"])

    def status(self, wall: str) -> dict[str, Any]:
        response = self.http.get(f"/api/walls/{wall}/status", headers=self.operator())
        response.raise_for_status()
        result: dict[str, Any] = response.json()
        return result

    def version(self, wall: str) -> int:
        """The wall's current state version (walls start past 0: their codes are shown)."""
        return int(self.status(wall)["version"])


# Debian Chromium as the browser tests and benchmarks drive it: headless in a sandbox
# without a GPU, and never throttled in the background (a tile is never "hidden").
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-dev-shm-usage",
    "--disable-background-networking",
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--disable-renderer-backgrounding",
    # as the kiosk (wall_client/kiosk.py): the video app's sound plays without a click
    "--autoplay-policy=no-user-gesture-required",
]

# Records, in a tile's page, the true time (performance.timeOrigin is never skewed) at
# which it showed each version: ``window.__shown[version]``. Observing the document
# itself, it also serves as an init script (run before the root element exists).
RECORD_SHOWN = """
window.__shown = {};
new MutationObserver(() => {
  window.__shown[document.body.dataset.version] = performance.timeOrigin + performance.now();
}).observe(document, {attributes: true, subtree: true, attributeFilter: ["data-version"]});
"""


def skewed_clock(skew_ms: int) -> str:
    """An init script that puts a page's ``Date.now`` ``skew_ms`` off the true time."""
    return (
        f"(() => {{ const now = Date.now.bind(Date); const skew = {skew_ms};"
        " Date.now = () => now() + skew; })();"
    )


@contextmanager
def fresh_database(postgres_url: str, folder: Path, name: str = "tagwall_test") -> Iterator[str]:
    """A database of its own: SQLite in ``folder``, or, given a PostgreSQL URL, a new
    database on that server, dropped afterwards (tests and benchmarks never share one)."""
    if not postgres_url:
        yield f"sqlite:///{folder / 'tagwall.db'}"
        return
    base = make_url(postgres_url)
    database = f"{name}_{uuid.uuid4().hex[:12]}"
    admin = create_engine(base, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{database}"'))
    try:
        yield base.set(database=database).render_as_string(hide_password=False)
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{database}" WITH (FORCE)'))
        admin.dispose()
