"""The census map as a wall app: what it costs a wall that never shows it, the data it
seeds and the codes it places as it comes on the wall and zooms, and what a restart
keeps."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.conftest import services_of
from tests.webapp.apps.census_map.walls import census_codes, change, placed, show_census, state_of
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.store import list_datasets


def test_walls_that_never_show_the_map_pay_nothing(client: TestClient) -> None:
    assert list_datasets(services_of(client).db) == []
    assert census_codes(client) == {}


def test_putting_the_map_up_seeds_the_data_and_places_its_codes(client: TestClient) -> None:
    state = show_census(client)
    [dataset] = list_datasets(services_of(client).db)
    assert dataset.tract_count == 403 and dataset.current
    assert CensusState.of(state).dataset == dataset.id and state.tag_set == "census"
    codes = census_codes(client)
    toggles = [name for name in codes if name.startswith("census:group:")]
    assert len(toggles) == 10 and "census:index" in codes
    on_wall = {p["code"] for p in placed(client, state)}
    assert {codes[name] for name in toggles} <= on_wall
    menu = services_of(client).walls["demo"].screen("menu")[0].id
    assert all(
        p["display"] == menu
        for p in placed(client, state)
        if p["code"] in {codes[n] for n in toggles}
    )


def test_zooming_in_places_more_codes_in_the_same_change(client: TestClient) -> None:
    before = show_census(client)
    tracts_before = [n for n in census_codes(client) if n.startswith("census:tract:")]
    result = change(client, {"view": {"center": [0.5, 0.5], "zoom": 4}})
    assert {"view", "tag_layout"} <= set(result["changed"]), "one change moves map and codes"
    after = state_of(client)
    tracts_after = [n for n in census_codes(client) if n.startswith("census:tract:")]
    assert len(tracts_after) > len(tracts_before)
    assert after.tag_layout != before.tag_layout
    codes = census_codes(client)
    placed_codes = {p["code"] for p in placed(client, after)}
    assert {codes[n] for n in tracts_after} & placed_codes


def test_a_restart_keeps_the_map_its_groups_and_its_codes(client: TestClient) -> None:
    from webapp.server.app import create_app

    show_census(client)
    codes = census_codes(client)
    group = next(n for n in codes if n.startswith("census:group:"))
    client.get(f"/t/{codes[group]}")
    before = state_of(client)
    with TestClient(create_app(services_of(client).settings)) as restarted:
        after = state_of(restarted)
        assert (
            after.app == "census"
            and CensusState.of(after).dataset == CensusState.of(before).dataset
        )
        assert after.layers == before.layers and after.tag_layout == before.tag_layout
        assert census_codes(restarted) == codes, "the same codes, still live"
        assert len(list_datasets(services_of(restarted).db)) == 1, "seeded once"
