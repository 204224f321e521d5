"""A burst of wrong sign-ins from one address: passwords checked and the server's peak memory.

One server process (``tagwall serve``, SQLite) with one instructor account. A browser
fetches the sign-in form once (its session and CSRF token), then sends ``BURST`` wrong
passwords for that account at once, as a script would. Each password check is an
argon2 verification (64 MiB of memory, a CPU-second across the cores); the throttle
allows ``TAGWALL_LOGIN_FREE_ATTEMPTS`` before it makes the client wait.

Measured: how many passwords the server checked (the audit log's ``login_failed``
entries), how many requests were answered 429, and the server's peak resident memory
(``VmHWM``) before and after the burst. The aims: no more checks than the throttle
allows, and a peak that does not grow with the burst.
"""

from __future__ import annotations

import asyncio
import re
import tempfile
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import func, select

from webapp.cli.testing import ServerProcess
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.database.models import AuditRecord
from webapp.people.accounts import add_account

BURST = 30
FREE_ATTEMPTS = 3
PASSWORD = "correct-horse-battery"
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')


def peak_rss_mb(pid: int) -> float:
    """The process's peak resident memory so far (Linux ``VmHWM``), in MB."""
    status = Path(f"/proc/{pid}/status").read_text()
    kilobytes = int(re.search(r"VmHWM:\s+(\d+) kB", status).group(1))  # type: ignore[union-attr]
    return kilobytes / 1024


async def _burst(url: str) -> dict[str, int]:
    async with httpx.AsyncClient(base_url=url, timeout=120) as browser:
        form = await browser.get("/login")
        csrf = _CSRF.search(form.text).group(1)  # type: ignore[union-attr]
        data = {"username": "ines", "password": "not-the-password", "csrf": csrf}
        answers = await asyncio.gather(*(browser.post("/login", data=data) for _ in range(BURST)))
    codes = [a.status_code for a in answers]
    return {str(code): codes.count(code) for code in sorted(set(codes))}


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        database_url = f"sqlite:///{tmp}/tagwall.db"
        upgrade(database_url)
        db = Database(database_url)
        add_account(db, "ines", "instructor", PASSWORD, actor="bench")
        server = ServerProcess(
            var_dir=Path(tmp) / "var",
            database_url=database_url,
            secret="benchmark-secret-not-for-production",
            extra_env={
                "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
                "TAGWALL_LOGIN_FREE_ATTEMPTS": str(FREE_ATTEMPTS),
            },
        )
        server.start()
        try:
            before = peak_rss_mb(server.pid)
            statuses = asyncio.run(_burst(server.url))
            after = peak_rss_mb(server.pid)
        finally:
            server.stop()
        with db.session() as session:
            checked = session.scalar(
                select(func.count()).where(AuditRecord.action == "login_failed")
            )
        db.dispose()
    return {
        "burst": BURST,
        "free_attempts": FREE_ATTEMPTS,
        "passwords_checked": checked,
        "statuses": statuses,
        "peak_rss_mb_before": round(before, 1),
        "peak_rss_mb_after": round(after, 1),
    }


def summary(result: dict[str, Any]) -> str:
    return (
        f"   {result['burst']} wrong sign-ins at once (throttle allows "
        f"{result['free_attempts']}): {result['passwords_checked']} passwords checked, "
        f"statuses {result['statuses']}; peak memory {result['peak_rss_mb_before']} -> "
        f"{result['peak_rss_mb_after']} MB"
    )
