"""Placing 1,000 tags on the 50-display HIPerWall (target: under 1 s).

Anchors are spread uniformly (seeded) over the whole wall, as a census map's tract
centres would be, plus the two registration codes. Two scanning distances: 3 m (the
wall's design distance, big codes, crowded displays) and 0.6 m (small codes, many
candidates per display).
"""

from __future__ import annotations

import random
import time
from typing import Any

from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm, symbol_modules
from wall_client.config import load_wall
from webapp.core.settings import CONTENT_DIR

TAGS = 1_000
DISTANCES_M = (3.0, 0.6)
ROUNDS = 3
SIZES = (symbol_modules(25), symbol_modules(21))  # version 2, falling back to version 1


def requests(width: float, height: float, distance_m: float) -> list[PlacementRequest]:
    rng = random.Random(2010)
    module = min_module_mm(distance_m)
    anchored = [
        PlacementRequest(
            key=f"T{index}",
            sizes=SIZES,
            module_mm=module,
            anchor=(rng.uniform(0, width), rng.uniform(0, height)),
        )
        for index in range(TAGS)
    ]
    slots = [
        PlacementRequest(
            key=f"R{slot}", sizes=SIZES, module_mm=module, screen="registration", slot=slot
        )
        for slot in range(2)
    ]
    return slots + anchored


def run() -> dict[str, Any]:
    wall = load_wall(CONTENT_DIR / "walls" / "hiperwall.toml")
    result: dict[str, Any] = {"wall": wall.id, "displays": len(wall.displays), "tags": TAGS}
    for distance in DISTANCES_M:
        batch = requests(wall.width, wall.height, distance)
        times = []
        for _ in range(ROUNDS):
            start = time.perf_counter()
            layout = place(wall, batch)
            times.append(time.perf_counter() - start)
        result[f"{distance:g}m"] = {
            "seconds": round(min(times), 3),
            "placed": len(layout.placed),
            "unplaced": len(layout.unplaced),
            "displaced": sum(p.leader is not None for p in layout.placed),
        }
    return result


def summary(result: dict[str, Any]) -> str:
    parts = [
        f"{key}: {value['seconds']:.3f} s, {value['placed']} placed, {value['unplaced']} unplaced"
        for key, value in result.items()
        if key.endswith("m") and isinstance(value, dict)
    ]
    return f"   {result['tags']} tags on {result['wall']}: " + "; ".join(parts)
