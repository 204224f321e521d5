"""Issuing codes and rendering them: how many per second.

* render: a fresh code's URL payload -> QR symbol (segno) -> SVG, all in memory.
* issue: registering a tag in the registry (one SQLite transaction each), as the tags
  API does, without HTTP.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

from tag_service.codes import make_symbol, new_code, render_svg, url_payload
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.tags.registry import TagSpec, issue

RENDERS = 2_000
ISSUES = 500
BASE_URL = "http://192.168.100.200:8000"


def run() -> dict[str, Any]:
    start = time.perf_counter()
    for _ in range(RENDERS):
        render_svg(make_symbol(url_payload(BASE_URL, new_code())))
    render_s = time.perf_counter() - start

    with tempfile.TemporaryDirectory() as tmp:
        url = f"sqlite:///{Path(tmp) / 'bench.db'}"
        upgrade(url)
        db = Database(url)
        spec = TagSpec(app="pattern", action="locate", anchor=(100.0, 100.0), tag_set="bench")
        start = time.perf_counter()
        for _ in range(ISSUES):
            issue(db, "demo", spec, "benchmark")
        issue_s = time.perf_counter() - start
        db.dispose()
    return {
        "render": {"count": RENDERS, "per_second": round(RENDERS / render_s, 1)},
        "issue_sqlite": {"count": ISSUES, "per_second": round(ISSUES / issue_s, 1)},
    }


def summary(result: dict[str, Any]) -> str:
    return (
        f"   code + SVG render {result['render']['per_second']:.0f}/s; "
        f"issue (SQLite) {result['issue_sqlite']['per_second']:.0f}/s"
    )
