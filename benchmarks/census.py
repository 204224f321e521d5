"""The census map: what the server does to build each tile's share of the map.

* Import of the shipped Sacramento data set into SQLite, and the one-off geometry
  (the plane, label points, the room for codes) per data set.
* Tract coverage at the whole-map view on every shipped wall: the share of tracts
  with their own code and with a cluster code once the wall's codes are placed.
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
from types import SimpleNamespace
from typing import Any

from wall_client.config import load_walls
from wall_client.layout import Wall
from webapp.apps.census_map.app import CensusApp
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.mapview import MapGeometry, tile_view, tract_codes
from webapp.apps.census_map.rules import APP, CENSUS_SET
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.store import SHIPPED, SHIPPED_KEY, load
from webapp.apps.registration.app import RegistrationApp
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.engine.wall_state import View, WallState
from webapp.tags.registry import (
    anchored_code_side_mm,
    anchored_footprint_mm,
    declare,
    get_layout,
    layout_for,
    wall_tags,
)

WALLS = ("demo", "hiperwall")
ZOOMS = (1.0, 3.0)
BASE_URL = "http://192.168.1.20:8000"


def _ms(seconds: float) -> float:
    return round(seconds * 1000, 1)


def _codes(db: Database, wall: Wall, dataset_id: int, total: int, view: View) -> dict[str, Any]:
    """The census map's codes for ``view`` as the server makes them (the app declares
    its tags, the wall's tag set is placed with the registration codes): how many
    tracts carry their own code, how many a cluster code, and how long that took."""
    services = SimpleNamespace(db=db, base_url=BASE_URL)
    state = CensusState(dataset=dataset_id).put(WallState(app=APP, view=view, tag_set=CENSUS_SET))
    started = time.perf_counter()
    specs = CensusApp().declare_tags(services, wall, state)  # type: ignore[arg-type]
    chosen = time.perf_counter()
    declare(db, wall.id, "core", RegistrationApp().declare_tags(services, wall, state))  # type: ignore[arg-type]
    declare(db, wall.id, APP, specs)
    layout = get_layout(db, wall.id, layout_for(db, wall, CENSUS_SET, BASE_URL, ("core", APP)))
    placed_at = time.perf_counter()
    assert layout is not None
    placed = {p["code"] for p in layout.placed}
    by_name = {tag.name: tag for tag in wall_tags(db, wall.id) if tag.active}
    own = clustered = 0
    for spec in specs:
        tag = by_name[spec.name]
        if tag.code not in placed:
            continue
        if spec.action == "tract":
            own += 1
        elif spec.action == "cluster":
            clustered += len(spec.params["geoids"])
    return {
        "own_code": own,
        "cluster_code": clustered,
        "own_share": round(own / total, 3),
        "cluster_share": round(clustered / total, 3),
        "unreached": total - own - clustered,
        "codes_placed": len(layout.placed),
        "codes_unplaced": [u["label"] for u in layout.unplaced],
        "choose_ms": _ms(chosen - started),
        "place_ms": _ms(placed_at - chosen),
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
        try:
            return _measure(db)
        finally:
            db.dispose()


def _measure(db: Database) -> dict[str, Any]:
    started = time.perf_counter()
    report = import_files(db, shapes=SHIPPED, key=SHIPPED_KEY)
    imported = time.perf_counter()
    dataset = load(db, report.dataset_id)
    loaded = time.perf_counter()
    assert dataset is not None
    geometry = MapGeometry.of(dataset)
    planed = time.perf_counter()
    result: dict[str, Any] = {
        "tracts": len(dataset.tracts),
        "import_s": round(imported - started, 2),
        "load_s": round(loaded - imported, 2),
        "geometry_s": round(planed - loaded, 2),
        "coverage": {},
        "walls": {},
    }
    walls = load_walls([CONTENT_DIR / "walls"])
    for name, wall in sorted(walls.items()):
        result["coverage"][name] = _codes(db, wall, dataset.id, len(dataset.tracts), View())
    for name in WALLS:
        wall = walls[name]
        per_view = {}
        for zoom in ZOOMS:
            geometry = MapGeometry.of(dataset)  # cold simplification per view, as after a restart
            view = View(center=(0.5, 0.5), zoom=zoom)
            codes = _codes(db, wall, dataset.id, len(dataset.tracts), view)
            own = tract_codes(
                geometry,
                wall,
                view,
                anchored_code_side_mm(BASE_URL, wall),
                anchored_footprint_mm(BASE_URL, wall),
            ).own
            per_view[f"zoom {zoom:g}"] = {
                "codes": codes,
                **_tiles(dataset, geometry, wall, view, {g: "ABCDEFG" for g in own}),
            }
        side = anchored_code_side_mm(BASE_URL, wall)
        result["walls"][name] = {"code_side_mm": round(side, 1), **per_view}
    return result


def summary(result: dict[str, Any]) -> str:
    lines = [
        f"   {result['tracts']} tracts: import {result['import_s']} s, load {result['load_s']} s, "
        f"geometry {result['geometry_s']} s",
        "   whole-map view, tracts reached by pointing at the wall:",
    ]
    for wall, c in result["coverage"].items():
        lines.append(
            f"     {wall}: {c['own_share']:.0%} their own code ({c['own_code']}),"
            f" {c['cluster_share']:.0%} a cluster code ({c['cluster_code']}),"
            f" {c['unreached']} unreached; {c['codes_placed']} codes placed,"
            f" unplaced: {', '.join(c['codes_unplaced']) or 'none'}"
        )
    for wall, views in result["walls"].items():
        for view, r in views.items():
            if not isinstance(r, dict):
                continue
            c = r["codes"]
            lines.append(
                f"   {wall} {view}: {c['own_code']} tracts with their own code, {c['cluster_code']}"
                f" under cluster codes (choose {c['choose_ms']} ms, place {c['place_ms']} ms,"
                f" {len(c['codes_unplaced'])} unplaced); tile view cold {r['cold_ms']} ms,"
                f" warm median {r['warm_median_ms']} ms, max {r['warm_max_ms']} ms;"
                f" {r['bytes_mean'] / 1e3:.0f} kB per tile on average"
                f" (max {r['bytes_max'] / 1e3:.0f} kB, gzip {r['gzip_bytes_mean'] / 1e3:.0f} kB)"
            )
    return "\n".join(lines)
