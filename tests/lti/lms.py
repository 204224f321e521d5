"""The test LMS (``tests/lti/platform.py``) as a process of its own, and what a test
does with it: point it at a tagwall, register it there, make it misbehave, read its
gradebook. It listens on ``localhost`` while tagwall's test servers listen on
``127.0.0.1``: two sites, so a launch in its frame is a third-party frame as on campus."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from webapp.cli.testing import free_port, wait_until
from webapp.core.settings import PROJECT_ROOT
from webapp.database.connection import Database
from webapp.lti.platforms import Platform, add_platform, tool_values


@dataclass
class TestLms:
    log: Path
    port: int = field(default_factory=free_port)
    process: subprocess.Popen[bytes] | None = None

    __test__ = False  # not a test class

    @property
    def url(self) -> str:
        return f"http://localhost:{self.port}"

    def start(self) -> None:
        with self.log.open("ab") as log:
            self.process = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "uvicorn",
                    "tests.lti.platform:app",
                    "--port",
                    str(self.port),
                    "--host",
                    "127.0.0.1",
                    "--log-level",
                    "warning",
                ],
                cwd=PROJECT_ROOT,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        wait_until(self._answers, timeout=60, what=f"the test LMS (log: {self.log})")

    def _answers(self) -> bool:
        assert self.process is not None
        if self.process.poll() is not None:
            raise RuntimeError(f"the test LMS exited:\n{self.log.read_text()[-3000:]}")
        try:
            return httpx.get(f"{self.url}/admin/gradebook", timeout=1).status_code == 200
        except httpx.HTTPError:
            return False

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(10)

    def serve(self, tool_base: str, db: Database) -> Platform:
        """A new course in the LMS whose tool is the tagwall at ``tool_base``, and the
        LMS registered in that tagwall's database (as `tagwall lti add` does)."""
        values = tool_values(tool_base)
        given = self._post(
            "/admin/tool",
            {
                "base": self.url,
                "tool": {
                    "login_url": str(values.login_url),
                    "launch_url": str(values.target_link_uri),
                    "jwks_url": str(values.jwks_url),
                },
            },
        )
        return add_platform(
            db,
            name="Test LMS",
            issuer=given["issuer"],
            client_id=given["client_id"],
            deployment_ids=[given["deployment_id"]],
            auth_url=f"{self.url}/auth",
            token_url=f"{self.url}/token",
            jwks_url=f"{self.url}/jwks",
            actor="test",
        )

    def misbehave(self, **what: Any) -> None:
        """Make the LMS go wrong (see ``State.misbehave``); nothing given: behave."""
        self._post("/admin/failures", what)

    def gradebook(self) -> dict[str, Any]:
        answer: dict[str, Any] = httpx.get(f"{self.url}/admin/gradebook", timeout=10).json()
        return answer

    def page(self, what: str, user: str) -> str:
        """The course page framing tagwall: ``deep-link`` to add it, else a link's id."""
        return f"{self.url}/course/bio101/{what}?user={user}"

    def _post(self, path: str, body: dict[str, Any]) -> dict[str, Any]:
        answer = httpx.post(f"{self.url}{path}", json=body, timeout=10)
        answer.raise_for_status()
        given: dict[str, Any] = answer.json()
        return given
