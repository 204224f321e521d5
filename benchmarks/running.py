"""What the browser benchmarks run against: ``tagwall serve`` on a fresh SQLite database
in a scratch folder, and Debian's Chromium as the tests drive it."""

from __future__ import annotations

import shutil
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

from playwright.sync_api import Browser, sync_playwright

from webapp.cli.testing import CHROMIUM_ARGS, ServerProcess

SECRET = "benchmark-secret-" + "x" * 32


@contextmanager
def tagwall_server(scratch: Path, extra_env: Mapping[str, str]) -> Iterator[ServerProcess]:
    """``tagwall serve`` with its var dir and database in ``scratch``, stopped after."""
    server = ServerProcess(
        var_dir=scratch / "var",
        database_url=f"sqlite:///{scratch / 'bench.db'}",
        secret=SECRET,
        extra_env=dict(extra_env),
    )
    server.start()
    try:
        yield server
    finally:
        server.stop()


@contextmanager
def chromium() -> Iterator[Browser]:
    """Debian's Chromium (software GL, as the browser tests run it), closed after."""
    executable = shutil.which("chromium")
    if executable is None:
        raise SystemExit("Debian chromium is not installed: run `make test` first")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=executable, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()
