"""Sync: how close together six demo tiles with skewed clocks apply one change.

Six Chromium pages (one per demo display, each in its own context) run with their
clocks skewed by up to half a second; the operator API makes a stream of light
changes. For each change:

* reported spread = the tiles' own ``applied`` reports (their server-time estimate
  when the frame went up): what the clock sync achieves;
* true spread = when each page really showed the version (``performance.timeOrigin``
  + ``performance.now()``, never skewed): what a person in front of the wall sees.

The test suite proves the mechanism with loose bounds; the targets live here.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from playwright.sync_api import Page

from benchmarks.running import chromium, tagwall_server
from webapp.cli.testing import RECORD_SHOWN, ServerProcess, skewed_clock, wait_until
from webapp.core.settings import CONTENT_DIR

WALL = "demo"
TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
SKEWS_MS = [-500, 500, -250, 250, 0, 400]
CHANGES = 30
TARGETS = {"median_reported_ms": 5.0, "median_true_ms": 10.0, "max_true_ms": 16.7}


def _version(page: Page) -> int | None:
    value = page.evaluate("document.body.dataset.version")
    return None if value is None else int(value)


def run() -> dict[str, Any]:
    extra_env = {
        "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
        "TAGWALL_APPLY_LEAD_MS": "400",
    }
    with (
        tempfile.TemporaryDirectory() as tmp,
        tagwall_server(Path(tmp), extra_env) as server,
        chromium() as browser,
    ):
        pages = []
        for tile, skew in zip(TILES, SKEWS_MS, strict=True):
            context = browser.new_context(viewport={"width": 480, "height": 270})
            context.add_init_script(skewed_clock(skew))
            page = context.new_page()
            page.goto(server.tile_url(WALL, tile))
            page.evaluate(RECORD_SHOWN)
            pages.append(page)
        start = server.version(WALL)
        wait_until(lambda: all(_version(p) == start for p in pages), what="tiles")
        time.sleep(3)  # clock sync converges within a few ping round trips
        reported, true = _measure(server, pages)
    return {
        "wall": WALL,
        "skews_ms": SKEWS_MS,
        "changes": CHANGES,
        "reported_spread_ms": _stats(reported),
        "true_spread_ms": _stats(true),
        "targets": TARGETS,
    }


def _measure(server: ServerProcess, pages: list[Page]) -> tuple[list[float], list[float]]:
    reported, true = [], []
    for index in range(CHANGES):
        version = server.change(WALL, {"layers": {"labels": index % 2 == 0}})
        time.sleep(1.0)  # keep polling away from the apply instant
        wait_until(lambda v=version: all(_version(p) == v for p in pages), what="the change")

        def applied(v: int = version) -> list[float]:
            tiles = server.status(WALL)["tiles"]
            return [t["applied_at"] for t in tiles if t["version"] == v]

        wait_until(lambda: len(applied()) == len(TILES), what="applied reports")
        times = applied()
        shown = [page.evaluate(f"window.__shown['{version}']") for page in pages]
        reported.append(max(times) - min(times))
        true.append(max(shown) - min(shown))
    return reported, true


def _stats(spreads: list[float]) -> dict[str, float]:
    ordered = sorted(spreads)
    return {
        "median": round(statistics.median(ordered), 2),
        "p90": round(ordered[int(0.9 * (len(ordered) - 1))], 2),
        "max": round(ordered[-1], 2),
    }


def summary(result: dict[str, Any]) -> str:
    reported, true = result["reported_spread_ms"], result["true_spread_ms"]
    return (
        f"   6 tiles, clocks skewed up to 500 ms, {result['changes']} changes: reported spread "
        f"median {reported['median']} / max {reported['max']} ms; true spread median "
        f"{true['median']} / p90 {true['p90']} / max {true['max']} ms"
    )
