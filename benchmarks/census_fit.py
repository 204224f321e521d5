"""How much of each shipped wall the census map fills at the whole-map view.

The shipped Sacramento data set, fitted to every shipped wall (``MapGeometry.fit``): the
displays its tracts cover, out of the displays that show the map (not designated
screens) and out of all, and how long the fit takes to make (cold: a fresh geometry,
its outline for the fit included). A display counts as covered when the tracts cover
at least :data:`COVERED_SHARE` of its active area, so one a corner of the map merely
grazes does not; ``touched`` counts every display any tract reaches. For comparison,
the same figures for the rule before the fit: the data's bounding box framed in the
wall's stage with 3 % of it kept free on every side.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import shapely

from wall_client.config import load_walls
from wall_client.layout import Wall
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.mapview import MapGeometry, Projection, projection
from webapp.apps.census_map.store import SHIPPED, SHIPPED_KEY, load
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.engine.wall_state import View

COVERED_SHARE = 0.1  # of a display's active area the tracts must cover for it to count
STAGE_MARGIN = 0.03  # the rule before the fit: of the stage, kept free on every side
ROUNDS = 3


def _before(geometry: MapGeometry, wall: Wall) -> Projection:
    """The data's bounding box fitted into the stage, centred on it."""
    minx, miny, maxx, maxy = geometry.extent
    stage = wall.stage
    scale = (1 - 2 * STAGE_MARGIN) * min(stage.width / (maxx - minx), stage.height / (maxy - miny))
    cx, cy = stage.center
    return Projection(scale, cx - scale * (minx + maxx) / 2, cy - scale * (miny + maxy) / 2)


def _displays(land: shapely.Geometry, project: Projection, wall: Wall) -> dict[str, Any]:
    """The displays the tracts cover, placed by ``project``."""
    placed = shapely.transform(land, lambda c: c * project.scale + (project.dx, project.dy))
    shares = {}
    for display in wall.displays:
        rect = wall.viewport(display.id).scene_rect
        shown = placed.intersection(shapely.box(rect.x, rect.y, rect.right, rect.bottom)).area
        shares[display.id] = shown / (rect.width * rect.height)
    covered = sorted(d for d, share in shares.items() if share >= COVERED_SHARE)
    return {
        "scale_mm_per_unit": round(project.scale, 1),
        "covered": len(covered),
        "touched": sum(share > 0 for share in shares.values()),
        "on_designated": sorted(d for d in wall.designated() if shares[d] > 0),
        "covered_displays": covered,
    }


def shipped_dataset() -> DataSet:
    """The shipped data set as the server has it: imported, then loaded."""
    with tempfile.TemporaryDirectory() as scratch:
        url = f"sqlite:///{Path(scratch) / 'bench.db'}"
        upgrade(url)
        db = Database(url)
        try:
            dataset = load(db, import_files(db, shapes=SHIPPED, key=SHIPPED_KEY).dataset_id)
        finally:
            db.dispose()
    assert dataset is not None
    return dataset


def run() -> dict[str, Any]:
    dataset = shipped_dataset()
    geometry = MapGeometry.of(dataset)
    land = shapely.union_all(geometry.shapes)
    walls = load_walls([CONTENT_DIR / "walls"])
    result: dict[str, Any] = {
        "tracts": len(dataset.tracts),
        "covered_share": COVERED_SHARE,
        "walls": {},
    }
    for name, wall in sorted(walls.items()):
        times = []
        for _ in range(ROUNDS):
            fresh = MapGeometry.of(dataset)
            started = time.perf_counter()
            fresh.fit(wall)
            times.append(time.perf_counter() - started)
        fitted = _displays(land, projection(geometry, wall, View()), wall)
        before = _displays(land, _before(geometry, wall), wall)
        result["walls"][name] = {
            "displays": len(wall.displays),
            "free": len(wall.displays) - len(wall.designated()),
            "fit_ms": round(min(times) * 1000, 1),
            "fit": fitted,
            "before": before,
            "scale_gain": round(fitted["scale_mm_per_unit"] / before["scale_mm_per_unit"], 3),
        }
    return result


def summary(result: dict[str, Any]) -> str:
    lines = [
        f"   {result['tracts']} tracts at the whole-map view; a display counts when they"
        f" cover {result['covered_share']:.0%} of it:"
    ]
    for name, r in result["walls"].items():
        fit, before = r["fit"], r["before"]
        lines.append(
            f"     {name}: {fit['covered']} of {r['free']} free displays ({r['displays']} in"
            f" all; {fit['touched']} touched), before {before['covered']} ({before['touched']}"
            f" touched); scale x{r['scale_gain']}; fit made in {r['fit_ms']} ms"
        )
    return "\n".join(lines)
