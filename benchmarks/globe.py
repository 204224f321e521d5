"""The census map on a globe under Chromium's software GL (SwiftShader, as the tests run
it): what a tile's first globe frame and a change's frame cost, each beside the same on
the flat map measured in the same run (the floor: the same page, tiles and change,
drawn without CesiumJS).

Each round opens the demo wall's two map tiles (r2c2, r2c3) at their native 1920 x 1080
in fresh browser contexts (nothing cached), first on the flat map, then on the globe:

* first frame: from the tile's navigation to the frame that shows the map
  (``data-census-surface`` turning "flat" or "globe"), both tiles loading at once as a
  wall's do;
* toggle: a group switched off or on (a light change: the tile draws it as it arrives),
  from the request to the frame shown, the server applying changes at once
  (``TAGWALL_APPLY_LEAD_MS=0``), so the time is the tile's drawing and not the lead;
* colour: the map coloured by a value or back to plain (a heavy change: every tile
  loads the classes and renders before the swap), from the request to the frame shown.

The browser test shows that the globe is right; only the times are here.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from playwright.sync_api import Browser, Page

from benchmarks.running import chromium, tagwall_server
from webapp.cli.testing import RECORD_SHOWN, ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR

WALL = "demo"
TILES = ["r2c2", "r2c3"]  # the demo's map tiles
NATIVE = {"width": 1920, "height": 1080}
GROUP = "tracts-0001-0038"  # a group of the shipped data set's tracts
THEME = {"attribute": "HH_INC", "scheme": "YlOrRd", "method": "quantiles", "classes": 5}
ROUNDS = 3
CHANGES = 4  # of each kind per round and surface
SURFACES = ("flat", "globe")
KINDS = ("first_frame", "toggle", "colour")

# When the tile first showed each surface (ms since its navigation began); an init
# script, so it observes the document (its root element is not there yet).
RECORD_SURFACE = """
window.__surface = {};
new MutationObserver(() => {
  const shown = document.body?.dataset.censusSurface;
  if (shown && !(shown in window.__surface)) window.__surface[shown] = performance.now();
}).observe(document, {attributes: true, subtree: true, attributeFilter: ["data-census-surface"]});
"""


def open_tiles(browser: Browser, server: ServerProcess, tiles: Sequence[str]) -> list[Page]:
    pages = []
    for tile in tiles:
        context = browser.new_context(viewport=NATIVE, device_scale_factor=1)
        context.add_init_script(RECORD_SURFACE + RECORD_SHOWN)
        page = context.new_page()
        page.goto(server.tile_url(WALL, tile))
        pages.append(page)
    return pages


def first_frames(pages: Sequence[Page], surface: str) -> list[float]:
    """Each page's milliseconds from its navigation to showing `surface`."""
    script = f"window.__surface[{surface!r}] ?? null"
    wait_until(
        lambda: all(p.evaluate(script) is not None for p in pages),
        timeout=600,  # software GL on a busy machine
        what=f"the tiles to show the {surface} map",
    )
    return [float(p.evaluate(script)) for p in pages]


def change_frames(
    server: ServerProcess, pages: Sequence[Page], make: Callable[[], int]
) -> list[float]:
    """Milliseconds from the request `make` sends to each page showing its version."""
    sent = time.time() * 1000  # the pages' true clocks are this machine's
    version = make()
    script = f"window.__shown[{str(version)!r}] ?? null"
    wait_until(
        lambda: all(p.evaluate(script) is not None for p in pages),
        timeout=300,
        what=f"the tiles to show version {version}",
    )
    return [float(p.evaluate(script)) - sent for p in pages]


def post(server: ServerProcess, path: str, body: dict[str, Any], timeout: float) -> None:
    """The operator's POST to the census map's API of the bench's wall."""
    server.http.post(
        f"/api/apps/census/walls/{WALL}/{path}",
        json=body,
        headers=server.operator(),
        timeout=timeout,
    ).raise_for_status()


def colour(server: ServerProcess, theme: dict[str, Any] | None) -> int:
    post(server, "theme", {"theme": theme}, timeout=120)
    return server.version(WALL)


def surface(server: ServerProcess, name: str) -> None:
    post(server, "surface", {"surface": name}, timeout=600)


def measure_round(
    browser: Browser, server: ServerProcess, name: str, tiles: Sequence[str], changes: int
) -> dict[str, list[float]]:
    """One surface's first frames and changes on fresh pages of `tiles`."""
    surface(server, name)
    pages = open_tiles(browser, server, tiles)
    try:
        measured: dict[str, list[float]] = {"first_frame": first_frames(pages, name)}
        measured["toggle"] = []
        measured["colour"] = []
        for index in range(changes):
            shown = index % 2 == 1  # off, on, off, ...: always a change
            measured["toggle"] += change_frames(
                server, pages, lambda s=shown: server.change(WALL, {"layers": {GROUP: s}})
            )
            theme = None if index % 2 else THEME
            measured["colour"] += change_frames(server, pages, lambda t=theme: colour(server, t))
        return measured
    finally:
        for page in pages:
            page.context.close()


def figures_of(samples: dict[str, dict[str, list[float]]]) -> dict[str, Any]:
    """Median and worst milliseconds per surface and kind, and the globe's medians over
    the flat map's (the floor measured beside it)."""
    figures: dict[str, Any] = {
        name: {
            kind: {
                "median_ms": round(statistics.median(values), 1),
                "max_ms": round(max(values), 1),
                "samples": len(values),
            }
            for kind, values in samples[name].items()
        }
        for name in SURFACES
    }
    figures["ratio"] = {
        kind: round(figures["globe"][kind]["median_ms"] / figures["flat"][kind]["median_ms"], 1)
        for kind in KINDS
    }
    return figures


def run(
    rounds: int = ROUNDS, changes: int = CHANGES, tiles: Sequence[str] = TILES
) -> dict[str, Any]:
    samples: dict[str, dict[str, list[float]]] = {s: {k: [] for k in KINDS} for s in SURFACES}
    load_before = os.getloadavg()[0]
    extra_env = {
        "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls" / f"{WALL}.toml"),
        "TAGWALL_APPLY_LEAD_MS": "0",  # a change's time is the tiles' drawing
    }
    with (
        tempfile.TemporaryDirectory() as tmp,
        tagwall_server(Path(tmp), extra_env) as server,
        chromium() as browser,
    ):
        server.change(WALL, {"app": "census"})
        for _ in range(rounds):
            for name in SURFACES:
                for kind, values in measure_round(browser, server, name, tiles, changes).items():
                    samples[name][kind] += values
    return {
        "wall": WALL,
        "tiles": list(tiles),
        "tile_px": [NATIVE["width"], NATIVE["height"]],
        "rounds": rounds,
        "changes_per_round": changes,
        "load_average_1min": [round(load_before, 1), round(os.getloadavg()[0], 1)],
        **figures_of(samples),
    }


def summary(result: dict[str, Any]) -> str:
    globe, flat, ratio = result["globe"], result["flat"], result["ratio"]
    lines = [
        f"   {len(result['tiles'])} tiles at {result['tile_px'][0]} x {result['tile_px'][1]}, "
        f"software GL, {result['rounds']} rounds (median, max ms; globe / flat map floor):"
    ]
    for kind in KINDS:
        lines.append(
            f"   {kind}: globe {globe[kind]['median_ms']} / {globe[kind]['max_ms']}, "
            f"flat {flat[kind]['median_ms']} / {flat[kind]['max_ms']}: {ratio[kind]}x"
        )
    return "\n".join(lines)
