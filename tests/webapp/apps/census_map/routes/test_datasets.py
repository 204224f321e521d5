"""The data sets and the colouring as the dashboard chooses them (``routes/datasets``):
staff only, what the data can have, kept across a restart."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.conftest import operator_headers, services_of
from tests.webapp.apps.census_map.test_acs import INCOME, VALUE, downloaded
from tests.webapp.apps.census_map.test_importer import write_shapefile
from tests.webapp.apps.census_map.walls import (
    INCOME_THEME,
    colour,
    placed,
    show_census,
    state_of,
    tile_theme,
)
from wall_client.layout import Rect
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.state import CensusState
from webapp.tags.schemas import PlacedCode


def test_choosing_the_data_set_needs_staff_and_a_real_one(client: TestClient) -> None:
    show_census(client)
    assert client.post("/api/apps/census/current", json={"dataset": 1}).status_code == 401
    assert (
        client.post(
            "/api/apps/census/current", json={"dataset": 42}, headers=operator_headers(client)
        ).status_code
        == 404
    )
    assert (
        client.post(
            "/api/apps/census/current", json={"dataset": "x"}, headers=operator_headers(client)
        ).status_code
        == 422
    )
    listed = client.get("/api/apps/census/datasets", headers=operator_headers(client)).json()
    assert [d["tracts"] for d in listed] == [403]
    detail = client.get(
        f"/api/apps/census/datasets/{listed[0]['id']}", headers=operator_headers(client)
    ).json()
    assert len(detail["groups"]) == 10


def test_the_instructor_colours_the_wall_by_a_value(client: TestClient) -> None:
    before = show_census(client)
    response = colour(client, INCOME_THEME)
    assert response.status_code == 200, response.text
    state = state_of(client)
    assert (
        CensusState.of(state).theme is not None
        and CensusState.of(state).theme.model_dump() == INCOME_THEME
    )
    assert state.tag_layout == before.tag_layout, "colour moves no code"
    body = tile_theme(client, state)
    assert len(body["classes"]) == 6 and len(body["tracts"]) == 403
    assert sum(1 for band in body["tracts"].values() if band < 0) == 0
    counts = [int(row["text"].split(" · ")[1].split()[0]) for row in body["classes"]]
    assert sum(counts) == 403
    legend = body["legend"]
    assert legend["title"] == "Median household income (1999)"
    assert legend["note"] == "6 classes by natural breaks"
    x, y, w, h = legend["rect"]
    wall = services_of(client).walls["demo"]
    [display] = [d for d in wall.displays if d.rect.intersects(Rect(x, y, w, h))]
    assert display.id not in {d.id for d in wall.screen("public")}, "never on the public screen"
    footprints = [Rect(*PlacedCode.model_validate(p).footprint) for p in placed(client, state)]
    assert not [f for f in footprints if f.intersects(Rect(x, y, w, h))], "clear of every code"
    assert tile_theme(client, state, "r1c1") == body, "the same for every tile"

    assert colour(client, None).status_code == 200
    assert CensusState.of(state_of(client)).theme is None


@pytest.mark.parametrize(
    ("theme", "status"),
    [
        ({"attribute": "NOPE"}, 404),
        ({"attribute": "HH_INC", "scheme": "Jet"}, 422),
        ({"attribute": "HH_INC", "classes": 12}, 422),
        ({"attribute": "HH_INC", "method": "kmeans"}, 422),
    ],
)
def test_a_colouring_the_data_cannot_have_is_refused(
    client: TestClient, theme: dict[str, Any], status: int
) -> None:
    show_census(client)
    assert colour(client, theme).status_code == status
    assert CensusState.of(state_of(client)).theme is None


def test_colouring_needs_staff_and_the_map_on_the_wall(client: TestClient) -> None:
    assert colour(client, INCOME_THEME).status_code == 409, "the map is not up"
    show_census(client)
    response = client.post("/api/apps/census/walls/demo/theme", json={"theme": INCOME_THEME})
    assert response.status_code == 401
    assert (
        client.post(
            "/api/apps/census/walls/nowall/theme",
            json={"theme": None},
            headers=operator_headers(client),
        ).status_code
        == 404
    )
    schemes = client.get("/api/apps/census/schemes", headers=operator_headers(client)).json()
    assert {"YlGnBu", "RdBu"} <= {s["name"] for s in schemes}
    assert all(len(s["colours"]) == 5 for s in schemes)


def test_a_colouring_survives_a_restart_and_leaves_with_a_data_set_without_its_value(
    client: TestClient, tmp_path: Path
) -> None:
    from webapp.server.app import create_app

    show_census(client)
    colour(client, INCOME_THEME)
    with TestClient(create_app(services_of(client).settings)) as restarted:
        theme = CensusState.of(state_of(restarted)).theme
        assert theme is not None and theme.model_dump() == INCOME_THEME
    new_id = import_files(
        services_of(client).db,
        shapes=write_shapefile(tmp_path / "tracts"),
        key="GEOID",
        tables=downloaded(tmp_path, INCOME, VALUE),
    ).dataset_id
    response = client.post(
        "/api/apps/census/current", json={"dataset": new_id}, headers=operator_headers(client)
    )
    assert response.status_code == 200
    state = state_of(client)
    assert CensusState.of(state).dataset == new_id and CensusState.of(state).theme is None, (
        "the ACS table has no HH_INC"
    )
