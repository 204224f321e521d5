"""The layouts the shipped apps put on the shipped walls, placed without a server.

The requests are the ones :func:`webapp.tags.registry.compute_layout` makes from the
apps' tags (URL codes, seat codes in slots, walk-up codes on anchors, captions on
labelled codes), in the order the apps' priorities give: the wall's registration codes,
the app's menu, then its anchored codes. Shared by the tests that hold these layouts to
the placement's rules and by measurements of them.
"""

from __future__ import annotations

from collections.abc import Sequence

from tag_service.placement import Layout, PlacementRequest, place
from tag_service.sizing import min_module_mm
from wall_client.config import load_walls
from wall_client.layout import Wall
from webapp.apps.brain_atlas.atlas import PIN_CLEARANCE_OF_CODE, pin_order
from webapp.apps.brain_atlas.rules import GROUP_LABELS
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.mapview import MapGeometry, TractCodes, tract_codes
from webapp.apps.registration.app import REGISTRATION_ROLES
from webapp.core.settings import CONTENT_DIR
from webapp.engine.wall_state import View
from webapp.tags.registry import (
    anchored_code_side_mm,
    anchored_footprint_mm,
    places_anchored,
    url_code_sizes,
)

BASE_URL = "http://192.168.1.20:8000"
Point = tuple[float, float]


def shipped_walls() -> dict[str, Wall]:
    return load_walls(sorted((CONTENT_DIR / "walls").glob("*.toml")))


def slot_requests(wall: Wall, screens: Sequence[tuple[str, str, int]]) -> list[PlacementRequest]:
    """The registration codes and ``screens`` (key, screen, slot) as labelled seat codes."""
    module_mm = min_module_mm(wall.seat_distance_m)
    slots = [
        (f"reg-{role}", "registration", slot) for slot, (role, _) in enumerate(REGISTRATION_ROLES)
    ]
    return [
        PlacementRequest(
            key=key,
            sizes=url_code_sizes(BASE_URL),
            module_mm=module_mm,
            screen=screen,
            slot=slot,
            caption=True,
        )
        for key, screen, slot in [*slots, *screens]
    ]


def anchored_requests(
    wall: Wall, anchors: Sequence[tuple[str, Point]], clear_mm: float = 0.0
) -> list[PlacementRequest]:
    """Labelled walk-up codes on ``anchors``, placed in this order."""
    module_mm = min_module_mm(wall.walk_up_distance_m)
    return [
        PlacementRequest(
            key=key,
            sizes=url_code_sizes(BASE_URL),
            module_mm=module_mm,
            anchor=anchor,
            clear_mm=clear_mm,
            caption=True,
        )
        for key, anchor in anchors
    ]


def brain_layout(wall: Wall, pins: Sequence[tuple[str, Point]]) -> Layout:
    """The brain atlas's layout: the user-group menu, and its pins (region id and scene
    point, in the content's order) each kept clear around its head, in the order the
    app places them (:func:`pin_order`)."""
    menu = [(f"group-{g}", "menu", slot) for slot, g in enumerate(GROUP_LABELS, start=1)]
    clear = PIN_CLEARANCE_OF_CODE * anchored_code_side_mm(BASE_URL, wall)
    heads = dict(pins)
    order = pin_order(pins, lambda anchors: places_anchored(wall, BASE_URL, anchors, clear))
    ordered = [(key, heads[key]) for key in order]
    return place(wall, slot_requests(wall, menu) + anchored_requests(wall, ordered, clear))


def census_codes(dataset: DataSet, geometry: MapGeometry, wall: Wall, view: View) -> TractCodes:
    """The tract and cluster codes the census map declares at ``view`` (tried first,
    as the app does: the tracts of a code without a spot join a cluster)."""
    side = anchored_code_side_mm(BASE_URL, wall)
    codes = tract_codes(geometry, wall, view, side, anchored_footprint_mm(BASE_URL, wall))
    return codes.settled(lambda anchors: places_anchored(wall, BASE_URL, anchors))


def census_layout(dataset: DataSet, wall: Wall, codes: TractCodes) -> Layout:
    """The census map's layout: the tract index, the group toggles and ``codes``."""
    menu = [("index", "registration", 2)]
    menu += [(f"toggle-{g.id}", "menu", n) for n, g in enumerate(dataset.groups, start=1)]
    return place(wall, slot_requests(wall, menu) + anchored_requests(wall, codes.anchors()))
