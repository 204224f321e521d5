"""The globe's camera and tours over HTTP, as the dashboard drives them: turn and tilt,
fly to a place, keep and play a tour; codes and balloons where a turned globe shows their
tracts."""

from __future__ import annotations

import math
import time
from typing import Any

import pytest
import shapely
from fastapi.testclient import TestClient

from tests.conftest import operator_headers, register_student, services_of
from tests.webapp.apps.census_map.walls import (
    census_codes,
    change,
    open_balloon,
    placed,
    show_census,
    state_of,
)
from wall_client.layout import Wall
from webapp.apps.census_map.globe import globe_projection, wall_middle
from webapp.apps.census_map.maps import census_maps
from webapp.apps.census_map.mapview import projection
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.tours import play_tour
from webapp.engine.wall_state import now_ms, read_state

WALL = "/api/apps/census/walls/demo"


def post(client: TestClient, path: str, body: Any = None) -> Any:
    return client.post(f"{WALL}{path}", json=body, headers=operator_headers(client))


def census(client: TestClient) -> CensusState:
    return CensusState.of(state_of(client))


def on_globe(client: TestClient) -> None:
    show_census(client)
    assert post(client, "/surface", {"surface": "globe"}).status_code == 200


def tract_codes(client: TestClient) -> set[str]:
    return {n for n in census_codes(client) if n.startswith(("census:tract:", "census:cluster:"))}


def test_on_a_turned_and_tilted_globe_codes_and_balloons_stand_on_their_tracts(
    client: TestClient,
) -> None:
    on_globe(client)
    change(client, {"view": {"center": [0.5, 0.5], "zoom": 3}})  # tracts with room for codes
    straight = tract_codes(client)
    assert straight, "codes stand on the tracts while the globe looks straight down"
    register_student(client)
    services = services_of(client)
    dataset = services.apps["census"].datasets.current(services.db)
    shown = sorted(n.removeprefix("census:tract:") for n in straight if "tract:" in n)
    assert open_balloon(client, shown[0]).status_code == 200
    assert state_of(client).balloons

    answer = post(client, "/camera", {"heading": 30, "tilt": 45})
    assert answer.status_code == 200, answer.text
    turned = census(client)
    assert (turned.heading, turned.tilt) == (30, 45)
    assert not state_of(client).balloons, "balloons pointing where their tracts were close"
    assert {n for n in census_codes(client) if n.startswith("census:group:")}, "toggles stay"

    # every tract's own code wants to stand inside its tract as the tilted globe shows it
    wall = services.walls["demo"]
    geometry = services.apps["census"].geometry(dataset)
    state = state_of(client)
    seen = globe_projection(geometry, wall, state.view, 30, 45)
    outline = {g: seen.outline(geometry.shapes[i]) for i, g in enumerate(geometry.geoids)}
    by_code = {code: name for name, code in census_codes(client).items()}
    own = {
        by_code[p["code"]].removeprefix("census:tract:"): p["anchor"]
        for p in placed(client, state)
        if by_code.get(p["code"], "").startswith("census:tract:")
    }
    clusters = [n for n in tract_codes(client) if n.startswith("census:cluster:")]
    assert len(own) >= 5 and clusters, (len(own), len(clusters))
    for geoid, anchor in own.items():
        assert outline[geoid].contains(shapely.Point(anchor)), geoid
    # ... and with the flat map's anchors most would not: the globe moved the tracts
    flat = projection(geometry, wall, state.view)
    off = [
        g
        for g in own
        if not outline[g].contains(
            shapely.Point(flat.point(*geometry.label_points[geometry.geoids.index(g)]))
        )
    ]
    assert len(off) >= len(own) / 2, (len(off), len(own))

    # balloons open, each pointing at its tract where the globe shows it
    with TestClient(client.app) as phone:
        for geoid in sorted(own)[:3]:
            change(client, {"balloons": []})
            opened = open_balloon(phone, geoid)
            assert opened.status_code == 200 and "on the wall for" in opened.text
            [balloon] = state_of(client).balloons
            dot = shapely.Point(balloon.anchor)
            assert outline[geoid].buffer(0.5).covers(dot), (geoid, balloon.anchor)

    # every tile asks for the same camera: the globe's answer follows the state
    cx, cy = state.view.center
    query = {"dataset": turned.dataset, "cx": cx, "cy": cy, "zoom": 3, "heading": 30, "tilt": 45}
    body = client.get("/api/apps/census/walls/demo/globe", params=query).json()
    assert (body["camera"]["heading"], body["camera"]["tilt"]) == (30, 45)

    assert post(client, "/camera", {"heading": 0, "tilt": 0}).status_code == 200
    assert tract_codes(client) == straight, "the same codes come back straight down"


def test_a_tract_the_globe_does_not_show_gets_no_balloon(client: TestClient) -> None:
    """Zoomed in on the globe, a tract far beyond the wall's edge: the phone says the
    globe looks elsewhere (409) rather than pointing a balloon at nothing."""
    on_globe(client)
    register_student(client)
    services = services_of(client)
    dataset = services.apps["census"].datasets.current(services.db)
    geometry = services.apps["census"].geometry(dataset)
    near = dataset.tracts[0].geoid
    assert post(client, "/fly", {"tract": near, "zoom": 20}).status_code == 200
    u, v = geometry.label_points[geometry.geoids.index(near)]
    far = max(
        geometry.geoids,
        key=lambda g: math.dist((u, v), geometry.label_points[geometry.geoids.index(g)]),
    )
    refused = open_balloon(client, far)
    assert refused.status_code == 409 and "looks elsewhere" in refused.text
    assert open_balloon(client, near).status_code == 200


@pytest.mark.parametrize(
    "camera",
    [
        {"heading": 0, "tilt": 61},
        {"heading": 0, "tilt": -1},
        {"heading": 360, "tilt": 0},
        {"heading": -5, "tilt": 0},
        {"heading": 10},
        {"heading": 10, "tilt": 10, "roll": 3},
    ],
)
def test_a_camera_out_of_bounds_is_refused(client: TestClient, camera: dict[str, Any]) -> None:
    on_globe(client)
    before = read_state(services_of(client).db, "demo")[0]
    assert post(client, "/camera", camera).status_code == 422
    assert read_state(services_of(client).db, "demo")[0] == before


@pytest.mark.parametrize("query", [{"tilt": 61}, {"heading": 360}, {"heading": -1}])
def test_a_globe_asked_for_out_of_bounds_is_refused(
    client: TestClient, query: dict[str, Any]
) -> None:
    show_census(client)
    dataset = census(client).dataset
    answer = client.get("/api/apps/census/walls/demo/globe", params={"dataset": dataset, **query})
    assert answer.status_code == 422


def test_the_colouring_is_asked_for_with_the_globe_s_camera(client: TestClient) -> None:
    """The legend keeps off the tracts where the wall shows them: tiles on the globe
    ask for the colouring with its camera, which is bounded as the globe's is."""
    on_globe(client)
    state = state_of(client)
    theme = {"attribute": "HH_INC", "scheme": "YlOrRd", "method": "quantiles", "classes": 5}
    cx, cy = state.view.center
    query = {"dataset": census(client).dataset, "cx": cx, "cy": cy, "zoom": 1, **theme}
    path = "/api/apps/census/walls/demo/tiles/r2c2/theme"
    for camera in ({}, {"surface": "globe", "heading": 30, "tilt": 45}):
        answer = client.get(path, params={**query, **camera})
        assert answer.status_code == 200, answer.text
        assert answer.json()["legend"]["rect"] is not None
    for camera in ({"surface": "sphere"}, {"surface": "globe", "tilt": 61}):
        assert client.get(path, params={**query, **camera}).status_code == 422


def test_the_camera_needs_the_map_on_the_wall(client: TestClient) -> None:
    assert post(client, "/camera", {"heading": 0, "tilt": 0}).status_code == 409
    assert post(client, "/fly", {"longitude": -121.5, "latitude": 38.5}).status_code == 409
    assert post(client, "/tour", None).status_code in (404, 405)  # PUT keeps a tour
    assert post(client, "/tour/play").status_code == 409
    answer = client.post(f"{WALL}/camera", json={"heading": 0, "tilt": 0})
    assert answer.status_code == 401


def shown_middle(client: TestClient) -> tuple[float, float]:
    """The plane point the middle of the wall shows now."""
    services = services_of(client)
    app = services.apps["census"]
    dataset = app.datasets.current(services.db)
    wall = services.walls["demo"]
    return projection(app.geometry(dataset), wall, state_of(client).view).to_plane(
        *wall_middle(wall)
    )


def test_fly_to_a_tract_a_group_or_a_place_moves_the_one_view(client: TestClient) -> None:
    on_globe(client)
    services = services_of(client)
    app = services.apps["census"]
    dataset = app.datasets.current(services.db)
    geometry = app.geometry(dataset)
    tract = dataset.tracts[42].geoid
    answer = post(client, "/fly", {"tract": tract, "zoom": 4})
    assert answer.status_code == 200, answer.text
    assert state_of(client).view.zoom == 4 and answer.json()["zoom"] == 4
    label = geometry.label_points[geometry.geoids.index(tract)]
    assert shown_middle(client) == pytest.approx(tuple(label))

    group = dataset.groups[1]
    assert post(client, "/fly", {"group": group.id}).status_code == 200
    assert state_of(client).view.zoom == 4, "the zoom kept"
    u, v = shown_middle(client)
    boxes = [geometry.bounds[i] for i, g in enumerate(geometry.geoids) if g in group.geoids]
    assert min(b[0] for b in boxes) < u < max(b[2] for b in boxes)
    assert min(b[1] for b in boxes) < v < max(b[3] for b in boxes)

    assert post(client, "/fly", {"longitude": -121.49, "latitude": 38.58}).status_code == 200
    assert geometry.to_lonlat(*shown_middle(client)) == pytest.approx((-121.49, 38.58))


@pytest.mark.parametrize(
    ("place", "status"),
    [
        ({"tract": "06067999999"}, 404),
        ({"group": "nope"}, 404),
        ({}, 422),
        ({"tract": "06067000100", "group": "x"}, 422),
        ({"longitude": -121.5}, 422),
        ({"longitude": -200, "latitude": 38}, 422),
        ({"longitude": -121.5, "latitude": 38, "zoom": 0}, 422),
    ],
)
def test_a_place_that_is_not_one_is_refused(
    client: TestClient, place: dict[str, Any], status: int
) -> None:
    show_census(client)
    before = state_of(client).view
    assert post(client, "/fly", place).status_code == status
    assert state_of(client).view == before


def keep_tour(client: TestClient, steps: list[dict[str, Any]]) -> Any:
    return client.put(f"{WALL}/tour", json={"steps": steps}, headers=operator_headers(client))


STEPS = [
    {"center": [0.4, 0.5], "zoom": 2, "heading": 90, "tilt": 30, "dwell_s": 2},
    {"center": [0.6, 0.45], "zoom": 3, "heading": 0, "tilt": 0, "dwell_s": 2},
]


def wait_for(check: Any, seconds: float = 15) -> None:
    until = time.monotonic() + seconds
    while not check():
        assert time.monotonic() < until, "waited too long"
        time.sleep(0.1)


def test_a_tour_plays_its_steps_in_turn_then_ends(client: TestClient) -> None:
    on_globe(client)
    assert post(client, "/tour/play").status_code == 409, "no steps yet"
    assert keep_tour(client, STEPS).status_code == 200
    assert census(client).tour.steps[1].zoom == 3 and not census(client).tour.playing
    answer = post(client, "/tour/play")
    assert answer.status_code == 200, answer.text
    first = state_of(client)
    assert CensusState.of(first).tour.playing and CensusState.of(first).tour.step == 0
    assert (first.view.center, first.view.zoom) == ((0.4, 0.5), 2)
    assert (CensusState.of(first).heading, CensusState.of(first).tilt) == (90, 30)
    wait_for(lambda: census(client).tour.step == 1)
    second = state_of(client)
    assert (second.view.center, second.view.zoom) == ((0.6, 0.45), 3)
    assert (CensusState.of(second).heading, CensusState.of(second).tilt) == (0, 0)
    assert tract_codes(client), "straight down again: codes on the tracts"
    wait_for(lambda: not census(client).tour.playing)
    assert census(client).tour.note == "played all 2 steps"
    assert state_of(client).view == second.view, "the last view kept"


def test_each_step_dwells_from_the_instant_the_tiles_show_it(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tiles slow to prepare a step (a globe picture under software GL: tens of
    seconds) swap it long after the change: the step still stays its dwell on the wall,
    counted from that swap, not from the change."""
    on_globe(client)
    keep_tour(client, STEPS)
    services = services_of(client)
    late_ms = 30_000
    shown: list[tuple[int, int]] = []  # (version, the instant the tiles show it)
    slept: list[tuple[int, float]] = []  # (when, how long)

    async def shown_at(wall: Wall, version: int) -> int:
        shown.append((version, now_ms() + late_ms))
        return shown[-1][1]

    async def sleep(seconds: float) -> None:
        slept.append((now_ms(), seconds))

    monkeypatch.setattr(services, "shown_at", shown_at)
    maps = census_maps(services)
    assert client.portal is not None
    client.portal.call(play_tour, maps, services, services.walls["demo"], sleep)
    wait_for(lambda: census(client).tour.note == "played all 2 steps")
    assert [version for version, _ in shown] == sorted({version for version, _ in shown})
    # every step is waited for until it shows (the tour's end is a change too: waited
    # for, not dwelt), and dwells from then
    assert len(slept) == len(STEPS) and len(shown) >= len(STEPS)
    for (_, instant), (when, seconds), step in zip(shown, slept, STEPS, strict=False):
        assert when + seconds * 1000 >= instant + step["dwell_s"] * 1000


def test_saving_a_tour_is_a_change_of_the_wall(client: TestClient) -> None:
    """Like every other change it bumps the wall's version (tiles and dashboards learn
    of it); keeping the same steps again changes nothing."""
    show_census(client)
    before = version_of(client)
    keep_tour(client, STEPS)
    assert version_of(client) == before + 1
    keep_tour(client, STEPS)
    assert version_of(client) == before + 1


def version_of(client: TestClient) -> int:
    version, _ = read_state(services_of(client).db, "demo")
    return version


def test_stopping_or_turning_stops_a_tour(client: TestClient) -> None:
    on_globe(client)
    long = [{**step, "dwell_s": 600} for step in STEPS]
    keep_tour(client, long)
    post(client, "/tour/play")
    answer = post(client, "/tour/stop")
    assert answer.status_code == 200 and not answer.json()["playing"]
    assert census(client).tour.note == "stopped at step 1 of 2: the instructor stopped it"
    post(client, "/tour/play")
    post(client, "/camera", {"heading": 15, "tilt": 0})
    assert census(client).tour.note.endswith("the instructor turned the camera")
    assert post(client, "/tour/stop").json()["playing"] is False, "nothing to stop: as it is"


@pytest.mark.parametrize(
    "step",
    [
        {"center": [0.5, 0.5], "zoom": 1, "tilt": 70, "dwell_s": 5},
        {"center": [0.5, 0.5], "zoom": 1, "dwell_s": 1},
        {"center": [0.5, 0.5], "zoom": 0, "dwell_s": 5},
        {"center": [0.5], "zoom": 1, "dwell_s": 5},
    ],
)
def test_a_tour_step_that_cannot_be_is_refused(client: TestClient, step: dict[str, Any]) -> None:
    show_census(client)
    assert keep_tour(client, [step]).status_code == 422
    assert keep_tour(client, [STEPS[0]] * 51).status_code == 422
    assert census(client).tour.steps == []


def test_a_tour_playing_when_the_server_stops_is_stopped_after_a_restart(
    client: TestClient,
) -> None:
    from webapp.server.app import create_app

    on_globe(client)
    keep_tour(client, [{**step, "dwell_s": 600} for step in STEPS])
    post(client, "/tour/play")
    assert census(client).tour.playing
    with TestClient(create_app(services_of(client).settings)) as restarted:
        _, after = read_state(services_of(restarted).db, "demo")
        kept = CensusState.of(after)
        assert not kept.tour.playing
        assert kept.tour.note == "stopped at step 1 of 2: the server restarted"
        assert len(kept.tour.steps) == 2, "its steps kept, to play again"
        assert (kept.surface, kept.heading, kept.tilt) == ("globe", 90, 30), "the camera kept"
