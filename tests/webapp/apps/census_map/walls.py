"""The census map on the demo wall as the tests drive it: the wall's changes, its
codes, a tile's share of the map and its colouring, a balloon opened from a phone."""

from __future__ import annotations

import itertools
from typing import Any

import shapely
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, services_of
from wall_client.layout import Rect
from webapp.apps.census_map.state import CensusState
from webapp.engine.wall_state import WallState, read_state
from webapp.tags.registry import get_layout, wall_tags
from webapp.tags.schemas import PlacedCode


def state_of(client: TestClient) -> WallState:
    return read_state(services_of(client).db, "demo")[1]


def change(client: TestClient, patch: dict[str, Any]) -> dict[str, Any]:
    response = client.post("/api/walls/demo/state", json=patch, headers=operator_headers(client))
    assert response.status_code == 200, response.text
    result: dict[str, Any] = response.json()
    return result


def show_census(client: TestClient) -> WallState:
    change(client, {"app": "census"})
    return state_of(client)


def census_codes(client: TestClient) -> dict[str, str]:
    """Live census tags by name -> code."""
    tags = wall_tags(services_of(client).db, "demo")
    return {t.name: t.code for t in tags if t.app == "census" and t.active and t.name}


def placed(client: TestClient, state: WallState) -> list[dict[str, Any]]:
    layout = get_layout(services_of(client).db, "demo", state.tag_layout)
    assert layout is not None
    return list(layout.placed)


def map_query(state: WallState) -> dict[str, Any]:
    """What a tile asks for its share of the map (and its colouring) in ``state``."""
    cx, cy = state.view.center
    return {
        "dataset": CensusState.of(state).dataset,
        "layout": state.tag_layout,
        "cx": cx,
        "cy": cy,
        "zoom": state.view.zoom,
    }


def tile_map(client: TestClient, state: WallState, tile: str = "r1c2") -> dict[str, Any]:
    response = client.get(f"/api/apps/census/walls/demo/tiles/{tile}", params=map_query(state))
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def open_balloon(client: TestClient, geoid: str) -> Any:
    return client.post(f"/apps/census/demo/tracts/{geoid}/balloon", data={"csrf": csrf_of(client)})


def assert_clear_of_every_code(
    client: TestClient, state: WallState, *, pointers: bool = True
) -> None:
    """Every open balloon's box, pointer (the line from the box's nearest point to its
    anchor, 2 px wide) and dot (4 px in radius; see balloons.js) stay clear of every
    code with its quiet zone and caption, and the box of other boxes and bezels.
    ``pointers=False`` where codes crowd the map so that no straight line reaches the
    tract between them: tiles draw pointers under the codes (tests/browser/test_census.py
    checks the pixels)."""
    wall = services_of(client).walls["demo"]
    px = max(d.mm_per_px for d in wall.displays)
    footprints = [
        shapely.box(x, y, x + w, y + h)
        for x, y, w, h in (PlacedCode.model_validate(p).footprint for p in placed(client, state))
    ]
    boxes = []
    for balloon in state.balloons:
        assert balloon.rect is not None
        x, y, w, h = balloon.rect
        ax, ay = balloon.anchor
        edge = (min(max(ax, x), x + w), min(max(ay, y), y + h))
        parts = {
            "box": shapely.box(x, y, x + w, y + h).buffer(px),  # its 2 px edge
            "dot": shapely.Point(ax, ay).buffer(4 * px),
        }
        if pointers:
            parts["pointer"] = shapely.LineString([edge, (ax, ay)]).buffer(px)
        for name, part in parts.items():
            hit = [f for f in footprints if f.intersects(part)]
            assert not hit, f"{balloon.id}: its {name} is drawn over a code or its caption"
        box = Rect(x, y, w, h)
        assert len([d for d in wall.displays if d.rect.intersects(box)]) == 1, "never on a bezel"
        boxes.append(box)
    for a, b in itertools.combinations(boxes, 2):
        assert not a.intersects(b)


# --- colouring the map ---------------------------------------------------------------

INCOME_THEME = {"attribute": "HH_INC", "scheme": "YlGnBu", "method": "natural", "classes": 6}


def colour(client: TestClient, theme: dict[str, Any] | None) -> Any:
    return client.post(
        "/api/apps/census/walls/demo/theme", json={"theme": theme}, headers=operator_headers(client)
    )


def tile_theme(client: TestClient, state: WallState, tile: str = "r2c1") -> dict[str, Any]:
    assert CensusState.of(state).theme is not None
    response = client.get(
        f"/api/apps/census/walls/demo/tiles/{tile}/theme",
        params={**map_query(state), **CensusState.of(state).theme.model_dump()},
    )
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body
