"""What each tile fetches of the census map (``routes/tiles``): its share of the tracts
with their codes and toggles, and of the colouring."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.webapp.apps.census_map.walls import (
    INCOME_THEME,
    census_codes,
    colour,
    map_query,
    placed,
    show_census,
    state_of,
    tile_map,
)
from webapp.apps.census_map.state import CensusState


def test_a_tile_gets_its_share_of_the_map_with_codes_and_toggles(client: TestClient) -> None:
    state = show_census(client)
    body = tile_map(client, state, "r2c2")  # the map is framed on the stage, r2c2 and r2c3
    assert body["dataset"] == CensusState.of(state).dataset and body["tracts"]
    assert not tile_map(client, state, "r1c2")["tracts"], "nothing lies under the public screen"
    codes = census_codes(client)
    tract_codes = {codes[f"census:tract:{t['id']}"] for t in body["tracts"] if t["code"]}
    assert tract_codes == {t["code"] for t in body["tracts"] if t["code"]}
    groups = {codes[f"census:group:{g}"]: g for g in body["toggles"].values()}
    groups_of_map = set(groups.values())
    assert body["toggles"] == groups and len(groups) == 10
    on_wall = {p["code"] for p in placed(client, state)}
    carried = sum(1 for n, c in codes.items() if n.startswith("census:tract:") and c in on_wall)
    clusters = {c for n, c in codes.items() if n.startswith("census:cluster:") and c in on_wall}
    assert clusters and set(body["clusters"]) == clusters
    assert all(set(groups) <= set(groups_of_map) for groups in body["clusters"].values())
    assert f"{carried} of 403 tracts carry their own code" in body["caption"]


@pytest.mark.parametrize(
    ("query", "status"),
    [
        ({"dataset": 99}, 404),
        ({"dataset": 0}, 422),
        ({"dataset": "x"}, 422),
        ({"dataset": 1, "zoom": -1}, 422),
        ({"dataset": 1, "zoom": "nan"}, 422),
        ({}, 422),
    ],
)
def test_bad_tile_map_requests(client: TestClient, query: dict[str, Any], status: int) -> None:
    show_census(client)
    assert client.get("/api/apps/census/walls/demo/tiles/r1c2", params=query).status_code == status


@pytest.mark.parametrize(
    "query",
    [
        {"attribute": "NOPE"},
        {"dataset": 999},
        {"scheme": "Jet"},
        {"classes": 2},
        {"layout": -1},
        {"zoom": 0},
    ],
)
def test_bad_tile_theme_requests(client: TestClient, query: dict[str, Any]) -> None:
    show_census(client)
    colour(client, INCOME_THEME)
    state = state_of(client)
    params = {**map_query(state), **INCOME_THEME, **query}
    response = client.get("/api/apps/census/walls/demo/tiles/r1c1/theme", params=params)
    assert response.status_code in (404, 422), response.text
    assert response.headers["content-type"].startswith("application/json")
