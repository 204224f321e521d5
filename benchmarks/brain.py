"""The brain atlas: what a view change and an answer cost the server.

* Loading the content and the two volumes (template and labels) once.
* Per view preset: finding the pins (which regions the picture shows and where) cold
  and from the cache, and placing them with their clearance beside the group menu on
  ``demo`` and ``hiperwall`` (how many pins stand, how many cannot).
* Judging answers: building a set's answer key, and the time per answer over every
  accepted name of the full set, each also with a typo.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from tag_service.codes import CODE_LENGTH, modules_across, symbol_variants, url_payload
from tag_service.placement import PlacementRequest, place
from tag_service.sizing import min_module_mm
from wall_client.config import load_wall
from webapp.apps.brain_atlas.atlas import PIN_CLEARANCE_OF_CODE
from webapp.apps.brain_atlas.content import load_content
from webapp.apps.brain_atlas.matching import answer_key
from webapp.apps.brain_atlas.pins import AtlasVolumes, PinCache, scene_pins
from webapp.apps.brain_atlas.views import load_views
from webapp.core.settings import CONTENT_DIR
from webapp.tags.registry import anchored_code_side_mm

WALLS = ("demo", "hiperwall")
BASE_URL = "http://192.168.1.20:8000"


def _ms(seconds: float) -> float:
    return round(seconds * 1000, 1)


def _typo(name: str) -> str:
    """The name with two neighbouring letters swapped in its middle."""
    i = len(name) // 2
    return name[: i - 1] + name[i] + name[i - 1] + name[i + 1 :] if len(name) > 4 else name


def run() -> dict[str, Any]:
    started = time.perf_counter()
    content = load_content()
    volumes = AtlasVolumes.load()
    loaded = time.perf_counter()
    presets = load_views()
    regions = content.regions
    result: dict[str, Any] = {"load_s": round(loaded - started, 2), "presets": {}, "walls": {}}
    cache = PinCache()
    for preset in presets:
        layer = preset.layer()
        began = time.perf_counter()
        plane = PinCache().get(volumes, regions, preset.view, layer)
        cold = time.perf_counter()
        cache.get(volumes, regions, preset.view, layer)
        cache.get(volumes, regions, preset.view, layer)
        warm = time.perf_counter()
        cache.get(volumes, regions, preset.view, layer)
        result["presets"][preset.id] = {
            "regions_shown": len(plane),
            "cold_ms": _ms(cold - began),
            "cached_us": round((time.perf_counter() - warm) * 1e6, 1),
        }
    payload = url_payload(BASE_URL, "0" * CODE_LENGTH)
    sizes = tuple(modules_across(s) for s in symbol_variants(payload))
    for name in WALLS:
        wall = load_wall(CONTENT_DIR / "walls" / f"{name}.toml")
        seat = min_module_mm(wall.seat_distance_m)
        walk_up = min_module_mm(wall.walk_up_distance_m)
        clear = PIN_CLEARANCE_OF_CODE * anchored_code_side_mm(BASE_URL, wall)
        per_preset = {}
        for preset in presets:
            plane = cache.get(volumes, regions, preset.view, preset.layer())
            for tag_set in ("full", "k5"):
                ids = {r.id for r in content.in_set(tag_set)}
                points = scene_pins(plane, wall, preset.view, volumes.meta)
                requests = [
                    PlacementRequest(
                        key=f"group-{i}",
                        sizes=sizes,
                        module_mm=seat,
                        screen="menu",
                        slot=i,
                        caption=True,
                    )
                    for i in range(1, 5)
                ] + [
                    PlacementRequest(
                        key=rid,
                        sizes=sizes,
                        module_mm=walk_up,
                        anchor=point,
                        clear_mm=clear,
                        caption=True,
                    )
                    for rid, point in points.items()
                    if rid in ids
                ]
                began = time.perf_counter()
                layout = place(wall, requests)
                per_preset[f"{preset.id} {tag_set}"] = {
                    "pins": len(requests) - 4,
                    "placed": sum(1 for p in layout.placed if not p.key.startswith("group-")),
                    "place_ms": _ms(time.perf_counter() - began),
                }
        result["walls"][name] = per_preset
    began = time.perf_counter()
    key = answer_key(content, "full")
    built = time.perf_counter()
    answers = [
        (region.id, text)
        for region in content.in_set("full")
        for name in [region.name, *region.synonyms]
        for text in (name, _typo(name))
    ]
    times = []
    for region_id, text in answers:
        one = time.perf_counter()
        key.judge(region_id, text)
        times.append(time.perf_counter() - one)
    result["judging"] = {
        "key_ms": _ms(built - began),
        "answers": len(answers),
        "median_ms": round(statistics.median(times) * 1000, 2),
        "max_ms": round(max(times) * 1000, 2),
    }
    return result


def summary(result: dict[str, Any]) -> str:
    lines = [f"   content and volumes loaded in {result['load_s']} s"]
    for preset, r in result["presets"].items():
        lines.append(
            f"   {preset}: {r['regions_shown']} regions shown, pins {r['cold_ms']} ms cold, "
            f"{r['cached_us']} µs cached"
        )
    for wall, per in result["walls"].items():
        cells = ", ".join(f"{k} {v['placed']}/{v['pins']}" for k, v in per.items())
        lines.append(f"   {wall} pins placed: {cells}")
    j = result["judging"]
    lines.append(
        f"   answer key {j['key_ms']} ms; {j['answers']} answers judged, median "
        f"{j['median_ms']} ms, max {j['max_ms']} ms"
    )
    return "\n".join(lines)
