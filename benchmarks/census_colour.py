"""Colouring the census map: what a theme costs the server and the tiles.

* Server: cutting the shipped data set's values into classes (quantiles, equal
  intervals, natural breaks; 5 and 7 classes), and the body every tile of a wall
  fetches (each tract's class, the legend placed clear of the codes): its bytes, and the
  time to fetch it over HTTP the first time (built) and again (cached).
* Tiles: drawing one display's share of the map in Chromium, plain and coloured (the
  coloured map outlines each tract inside its own edge), on the demo wall's busiest
  tile and HIPerWall's (the one showing the most tracts): the census layer's draw call
  at the tile's own canvas size, timed over repeated frames.
"""

from __future__ import annotations

import gzip
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
from playwright.sync_api import Page

from benchmarks.census_fit import shipped_dataset
from benchmarks.running import chromium, tagwall_server
from webapp.apps.census_map.theme import shade
from webapp.choropleth.classes import Method, Theme
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR

THEME: dict[str, str | int] = {
    "attribute": "HSG_VAL",
    "scheme": "YlOrRd",
    "method": "quantiles",
    "classes": 7,
}
WALLS = {"demo": (1920, 1080), "hiperwall": (2560, 1600)}  # each with its tiles' size
FRAMES = 30


def _ms(seconds: float) -> float:
    return round(seconds * 1000, 2)


def _cuts() -> dict[str, float]:
    """Milliseconds to cut the shipped values into classes, per method and count."""
    dataset = shipped_dataset()
    timings = {}
    methods: tuple[Method, ...] = ("quantiles", "equal", "natural")
    for method in methods:
        for classes in (5, 7):
            theme = Theme(attribute="HSG_VAL", method=method, classes=classes)
            started = time.perf_counter()
            shade(dataset, theme)
            timings[f"{method} {classes}"] = _ms(time.perf_counter() - started)
    return timings


DRAW = """async ([view, theme, display, frames]) => {
  const {drawCensus} = await import("/static/apps/census/census.js");
  const canvas = document.createElement("canvas");
  [canvas.width, canvas.height] = display.resolution;
  const ctx = canvas.getContext("2d");
  const state = {app: "census", layers: {}};
  const times = [];
  for (let i = 0; i < frames; i++) {
    const started = performance.now();
    drawCensus(ctx, view, state, display, theme);
    ctx.getImageData(0, 0, 1, 1);  // wait for the frame to be drawn
    times.push(performance.now() - started);
  }
  times.sort((a, b) => a - b);
  return {median: times[Math.floor(times.length / 2)], max: times[times.length - 1]};
}"""


def _busiest(server: ServerProcess, wall: str, query: dict[str, Any]) -> tuple[str, Any]:
    """The tile showing the most tracts (downtown), and its share of the map."""
    displays = httpx.get(f"{server.url}/api/walls/{wall}", timeout=60).json()["displays"]
    views = {
        d["id"]: httpx.get(
            f"{server.url}/api/apps/census/walls/{wall}/tiles/{d['id']}",
            params={**query, "cx": 0.5, "cy": 0.5, "zoom": 1},
            timeout=60,
        )
        for d in displays
    }
    return max(views.items(), key=lambda item: len(item[1].json()["tracts"]))


def _tile(server: ServerProcess, page: Page, wall: str) -> dict[str, Any]:
    """The body tiles fetch for the theme, and the draw time of the busiest tile."""
    server.change(wall, {"app": "census"})
    coloured_wall = httpx.post(
        f"{server.url}/api/apps/census/walls/{wall}/theme",
        json={"theme": THEME},
        headers=server.operator(),
        timeout=60,
    )
    assert coloured_wall.status_code == 200, coloured_wall.text
    state = server.status(wall)["state"]
    query = {"dataset": state["apps"]["census"]["dataset"], "layout": state["tag_layout"]}
    tile, view = _busiest(server, wall, query)
    base = f"{server.url}/api/apps/census/walls/{wall}/tiles/{tile}"
    with httpx.Client(timeout=60) as client:  # one connection: the fetch, not the setup
        client.get(f"{server.url}/healthz")
        started = time.perf_counter()
        coloured = client.get(f"{base}/theme", params={**query, **THEME})
        built = time.perf_counter() - started
        started = time.perf_counter()
        client.get(f"{base}/theme", params={**query, **THEME})
        cached = time.perf_counter() - started
    page.goto(server.tile_url(wall, tile))
    wait_until(lambda: page.evaluate("document.body.dataset.census || ''"), what="the tile")
    info = page.evaluate("JSON.parse(document.body.dataset.wallInfo)")
    display = next(d for d in info["displays"] if d["id"] == tile)
    plain = page.evaluate(DRAW, [view.json(), None, display, FRAMES])
    themed = page.evaluate(DRAW, [view.json(), coloured.json(), display, FRAMES])
    return {
        "tile": tile,
        "tracts_on_tile": len(view.json()["tracts"]),
        "theme_fetch_first_ms": _ms(built),
        "theme_fetch_cached_ms": _ms(cached),
        "theme_bytes": len(coloured.content),
        "theme_gzip_bytes": len(gzip.compress(coloured.content)),
        "theme_bytes_per_wall": len(coloured.content) * len(info["displays"]),
        "view_bytes": len(view.content),
        "draw_plain_ms": round(plain["median"], 2),
        "draw_coloured_ms": round(themed["median"], 2),
        "draw_coloured_max_ms": round(themed["max"], 2),
    }


def run() -> dict[str, Any]:
    result: dict[str, Any] = {"theme": THEME, "cut_ms": _cuts(), "walls": {}}
    extra_env = {"TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls")}
    with (
        tempfile.TemporaryDirectory() as tmp,
        tagwall_server(Path(tmp), extra_env) as server,
        chromium() as browser,
    ):
        for wall, (width, height) in WALLS.items():
            context = browser.new_context(
                viewport={"width": width, "height": height}, device_scale_factor=1
            )
            result["walls"][wall] = _tile(server, context.new_page(), wall)
            context.close()
    return result


def summary(result: dict[str, Any]) -> str:
    cuts = ", ".join(f"{name} {ms} ms" for name, ms in result["cut_ms"].items())
    lines = [f"   cutting 403 values into classes: {cuts}"]
    for wall, r in result["walls"].items():
        lines.append(
            f"   {wall} {r['tile']} ({r['tracts_on_tile']} tracts): theme body"
            f" {r['theme_bytes'] / 1e3:.1f} kB (gzip {r['theme_gzip_bytes'] / 1e3:.1f} kB), fetched"
            f" in {r['theme_fetch_first_ms']} ms (cached {r['theme_fetch_cached_ms']} ms);"
            f" draw plain {r['draw_plain_ms']} ms, coloured {r['draw_coloured_ms']} ms"
            f" (max {r['draw_coloured_max_ms']} ms)"
        )
    return "\n".join(lines)
