"""The census map: what the server does to build each tile's share of the map.

* Import of the shipped Sacramento data set into SQLite, and the one-off geometry
  (the plane, label points, the room for codes) per data set.
* Codes for a view: which tracts carry one and placing them with the wall's other
  codes (the menu's toggles, the registration codes), for ``demo`` and ``hiperwall``
  at zoom 1 and 3.
* Per tile: building its view (projection, clipping, simplification, labels) cold
  (the first tile after a view change, simplified outlines built on demand) and warm
  (the others), and the bytes sent, raw and gzip-compressed.
"""

from __future__ import annotations

import gzip
import json
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

from tag_service.codes import CODE_LENGTH, modules_across, symbol_variants, url_payload
from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm
from wall_client.layout import Wall, load_wall
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.mapview import MapGeometry, code_anchors, tile_view
from webapp.apps.census_map.store import SHIPPED, SHIPPED_KEY, load
from webapp.db import Database
from webapp.migrate import upgrade
from webapp.settings import CONTENT_DIR
from webapp.tags import anchored_code_side_mm
from webapp.wall_state import View

WALLS = ("demo", "hiperwall")
ZOOMS = (1.0, 3.0)
BASE_URL = "http://192.168.1.20:8000"


def _ms(seconds: float) -> float:
    return round(seconds * 1000, 1)


def _codes(wall: Wall, geometry: MapGeometry, view: View, side_mm: float) -> dict[str, Any]:
    """Which tracts carry a code at ``view``, then placing them with ten menu toggles."""
    started = time.perf_counter()
    anchors = code_anchors(geometry, wall, view, side_mm)
    chosen = time.perf_counter()
    payload = url_payload(BASE_URL, "0" * CODE_LENGTH)
    sizes = tuple(modules_across(s) for s in symbol_variants(payload))
    module = min_module_mm(wall.scan_distance_m)
    requests = [
        PlacementRequest(key=f"toggle-{i}", sizes=sizes, module_mm=module, screen="menu", slot=i)
        for i in range(10)
    ] + [
        PlacementRequest(key=geoid, sizes=sizes, module_mm=module, anchor=anchor)
        for geoid, anchor in anchors.items()
    ]
    layout = place(wall, requests)
    placed = time.perf_counter()
    return {
        "tracts_with_codes": len(anchors),
        "choose_ms": _ms(chosen - started),
        "place_ms": _ms(placed - chosen),
        "placed": len(layout.placed),
        "unplaced": len(layout.unplaced),
    }


def _tiles(
    dataset: Any, geometry: MapGeometry, wall: Wall, view: View, codes: dict[str, str]
) -> dict[str, Any]:
    times, sizes, packed, tracts = [], [], [], []
    cold = None
    for display in wall.displays:
        started = time.perf_counter()
        body = json.dumps(
            tile_view(dataset, geometry, wall, display.id, view, codes), separators=(",", ":")
        ).encode()
        elapsed = time.perf_counter() - started
        if cold is None:
            cold = elapsed
        else:
            times.append(elapsed)
        sizes.append(len(body))
        packed.append(len(gzip.compress(body)))
        tracts.append(body.count(b'"rings"'))
    return {
        "tiles": len(wall.displays),
        "cold_ms": _ms(cold or 0.0),
        "warm_median_ms": _ms(statistics.median(times)) if times else None,
        "warm_max_ms": _ms(max(times)) if times else None,
        "tracts_per_tile_max": max(tracts),
        "bytes_mean": round(statistics.mean(sizes)),
        "bytes_max": max(sizes),
        "gzip_bytes_mean": round(statistics.mean(packed)),
        "gzip_bytes_max": max(packed),
        "wall_bytes": sum(sizes),
    }


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as scratch:
        url = f"sqlite:///{Path(scratch) / 'bench.db'}"
        upgrade(url)
        db = Database(url)
        started = time.perf_counter()
        report = import_files(db, shapes=SHIPPED, key=SHIPPED_KEY)
        imported = time.perf_counter()
        dataset = load(db, report.dataset_id)
        loaded = time.perf_counter()
        db.dispose()
    assert dataset is not None
    geometry = MapGeometry.of(dataset)
    planed = time.perf_counter()
    result: dict[str, Any] = {
        "tracts": len(dataset.tracts),
        "import_s": round(imported - started, 2),
        "load_s": round(loaded - imported, 2),
        "geometry_s": round(planed - loaded, 2),
        "walls": {},
    }
    for name in WALLS:
        wall = load_wall(CONTENT_DIR / "walls" / f"{name}.toml")
        side = anchored_code_side_mm(BASE_URL, wall)
        per_view = {}
        for zoom in ZOOMS:
            geometry = MapGeometry.of(dataset)  # cold simplification per view, as after a restart
            view = View(center=(0.5, 0.5), zoom=zoom)
            codes = _codes(wall, geometry, view, side)
            anchors = code_anchors(geometry, wall, view, side)
            per_view[f"zoom {zoom:g}"] = {
                "codes": codes,
                **_tiles(dataset, geometry, wall, view, {g: "ABCDEFG" for g in anchors}),
            }
        result["walls"][name] = {"code_side_mm": round(side, 1), **per_view}
    return result


def summary(result: dict[str, Any]) -> str:
    lines = [
        f"   {result['tracts']} tracts: import {result['import_s']} s, load {result['load_s']} s, "
        f"geometry {result['geometry_s']} s"
    ]
    for wall, views in result["walls"].items():
        for view, r in views.items():
            if not isinstance(r, dict):
                continue
            c = r["codes"]
            lines.append(
                f"   {wall} {view}: {c['tracts_with_codes']} tracts with codes "
                f"(choose {c['choose_ms']} ms, place {c['place_ms']} ms, {c['unplaced']} unplaced);"
                f" tile view cold {r['cold_ms']} ms, warm median {r['warm_median_ms']} ms, max "
                f"{r['warm_max_ms']} ms; {r['bytes_mean'] / 1e3:.0f} kB per tile on average "
                f"(max {r['bytes_max'] / 1e3:.0f} kB, gzip {r['gzip_bytes_mean'] / 1e3:.0f} kB)"
            )
    return "\n".join(lines)
