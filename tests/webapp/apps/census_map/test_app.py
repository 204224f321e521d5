"""The census map over HTTP, as the dashboard, tiles and phones use it."""

from __future__ import annotations

import itertools
import re
from pathlib import Path
from typing import Any

import pytest
import shapely
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, register_student, services_of, sign_in
from tests.webapp.apps.census_map.test_acs import INCOME, VALUE, downloaded
from tests.webapp.apps.census_map.test_importer import (
    DC,
    polygon,
    square,
    write_geojson,
    write_shapefile,
)
from wall_client.layout import Rect
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.mapview import projection, shown_area
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.store import list_datasets
from webapp.engine.wall_state import View, WallState, read_state
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


def test_scanning_a_toggle_flips_its_group_on_the_wall(client: TestClient) -> None:
    show_census(client)
    codes = census_codes(client)
    name = next(n for n in codes if n.startswith("census:group:"))
    group = name.removeprefix("census:group:")
    page = client.get(f"/t/{codes[name]}")
    assert page.status_code == 200 and "Hidden on the wall now" in page.text
    assert state_of(client).layers[group] is False
    again = client.get(f"/t/{codes[name]}")
    assert "Shown on the wall now" in again.text and state_of(client).layers[group] is True
    # the page's button flips it too (another phone's: this one has flipped it twice
    # in a moment, all one phone may, see test_limits.py)
    other = TestClient(client.app)  # type: ignore[arg-type]
    form = other.post(f"/apps/census/demo/groups/{group}/toggle", data={"csrf": csrf_of(other)})
    assert form.status_code == 200 and state_of(client).layers[group] is False


def test_toggle_form_needs_its_csrf_token_and_a_real_group(client: TestClient) -> None:
    show_census(client)
    assert client.post("/apps/census/demo/groups/tracts-0001-0038/toggle").status_code == 403
    missing = client.post("/apps/census/demo/groups/nope/toggle", data={"csrf": csrf_of(client)})
    assert missing.status_code == 404


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


def test_show_on_the_wall_opens_a_balloon_clear_of_every_code(client: TestClient) -> None:
    show_census(client)
    register_student(client)
    dataset = services_of(client).apps["census"].datasets.current(services_of(client).db)
    geoids = [dataset.tracts[i].geoid for i in (0, 150, 300)]
    for geoid in geoids:
        response = open_balloon(client, geoid)
        assert response.status_code == 200 and "on the wall for 30 seconds" in response.text
    after = state_of(client)
    assert [b.id for b in after.balloons] == [f"tract-{g}" for g in geoids]
    assert_clear_of_every_code(client, after, pointers=False)  # the whole map: codes crowd it
    first = after.balloons[0]
    assert first.closes_at is not None and first.title == dataset.tract_title(dataset.tracts[0])
    assert any("Total population" in line for line in first.lines)

    # zoomed in, tracts carry their own codes on their label points: a balloon points at
    # the tract beside its code, not into it, and its pointer runs clear of every code.
    # Taken among the tracts lying wholly on the displays that show the map: one mostly
    # under the menu screen may leave a sliver with no room for a box within reach, and
    # then its pointer passes under codes, as where codes crowd the map.
    change(client, {"view": {"center": [0.5, 0.5], "zoom": 3}, "balloons": []})
    codes = census_codes(client)
    wall = services_of(client).walls["demo"]
    geometry = services_of(client).apps["census"].geometry(dataset)
    project = projection(geometry, wall, View(zoom=3))
    shown = shown_area(wall)
    own = [
        geoid
        for geoid in sorted(
            n.removeprefix("census:tract:") for n in codes if n.startswith("census:tract:")
        )
        if shown.covers(
            shapely.transform(
                geometry.shapes[geometry.geoids.index(geoid)],
                lambda c: c * project.scale + (project.dx, project.dy),
            )
        )
    ]
    assert len(own) >= 5
    with TestClient(client.app) as phone:  # a phone of its own: within its action limit
        for geoid in own[:5]:
            change(client, {"balloons": []})
            assert open_balloon(phone, geoid).status_code == 200
            assert_clear_of_every_code(client, state_of(client))
    # five at once crowd the map: boxes and dots stay clear, pointers may pass under codes
    with TestClient(client.app) as phone:
        for geoid in own[:5]:
            assert open_balloon(phone, geoid).status_code == 200
    together = state_of(client)
    assert len(together.balloons) == 5
    assert_clear_of_every_code(client, together, pointers=False)


def test_a_balloon_stands_beside_its_tract_and_no_publication_covers_its_pointer(
    client: TestClient,
) -> None:
    """Zoomed in, a tract on the lower right display got its balloon on the upper left
    one, its pointer 1.6 m long and under the public screen's publication: a person
    finds neither the box by the tract nor the line between them. Each balloon stands
    beside its tract (its pointer within one and a half times the box's longer side; it
    passes under codes where they crowd the tract) and its pointer misses the public
    screen."""
    show_census(client)
    change(client, {"view": {"center": [0.5, 0.5], "zoom": 2.25}})
    codes = census_codes(client)
    own = sorted(n.removeprefix("census:tract:") for n in codes if n.startswith("census:tract:"))
    assert len(own) >= 8
    wall = services_of(client).walls["demo"]
    screens = [wall.viewport(d.id).scene_rect for d in wall.screen("public")]
    public = [shapely.box(r.x, r.y, r.right, r.bottom) for r in screens]
    far = []
    with TestClient(client.app) as phone:
        for geoid in own:
            change(client, {"balloons": []})
            assert open_balloon(phone, geoid).status_code == 200
            [balloon] = state_of(client).balloons
            assert balloon.rect is not None
            x, y, w, h = balloon.rect
            ax, ay = balloon.anchor
            pointer = shapely.LineString(
                [(min(max(ax, x), x + w), min(max(ay, y), y + h)), (ax, ay)]
            )
            if pointer.length > 1.5 * max(w, h) or any(pointer.intersects(p) for p in public):
                far.append((geoid, round(pointer.length)))
    assert not far, f"balloons away from their tracts (pointer mm): {far}"


def test_no_room_for_a_balloon_clear_of_the_codes_is_said_not_papered_over(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A wall full of codes and balloons: the balloon is not drawn over a code anyway."""
    show_census(client)
    register_student(client)
    monkeypatch.setattr("webapp.apps.census_map.actions.place_box", lambda *a, **kw: None)
    response = open_balloon(client, "06061022001")
    assert response.status_code == 409
    assert "No room on the wall for its balloon now" in response.text
    assert state_of(client).balloons == []


def test_a_tract_whose_group_is_hidden_gets_no_balloon_and_the_phone_says_why(
    client: TestClient,
) -> None:
    """Its tract is not drawn: a balloon would point at empty map. The tract page offers
    to show the group instead, and leads back to the tract once it is shown."""
    show_census(client)
    register_student(client)
    dataset = services_of(client).apps["census"].datasets.current(services_of(client).db)
    tract = dataset.tracts[0]
    group = dataset.group_of[tract.geoid]
    hide = client.post(f"/apps/census/demo/groups/{group}/toggle", data={"csrf": csrf_of(client)})
    assert "Hidden on the wall now" in hide.text

    page = client.get(f"/apps/census/demo/tracts/{tract.geoid}").text
    assert 'id="show-on-wall"' not in page, "no button for a balloon the wall cannot show"
    assert "is hidden on the wall now, so a balloon would point at empty map" in page
    assert f'action="/apps/census/demo/groups/{group}/toggle"' in page
    refused = open_balloon(client, tract.geoid)  # a form sent before the group was hidden
    assert refused.status_code == 409
    assert "No balloon opened: its group, tracts" in refused.text
    assert f'name="tract" value="{tract.geoid}"' in refused.text
    assert state_of(client).balloons == []

    shown = client.post(
        f"/apps/census/demo/groups/{group}/toggle",
        data={"csrf": csrf_of(client), "tract": tract.geoid},
    )
    assert "Shown on the wall now" in shown.text
    assert f'href="/apps/census/demo/tracts/{tract.geoid}">{dataset.tract_title(tract)}' in (
        shown.text
    )
    assert 'id="show-on-wall"' in client.get(f"/apps/census/demo/tracts/{tract.geoid}").text
    assert open_balloon(client, tract.geoid).status_code == 200
    assert [b.id for b in state_of(client).balloons] == [f"tract-{tract.geoid}"]


def test_reopening_a_balloon_replaces_it_and_at_most_eight_stay_open(client: TestClient) -> None:
    show_census(client)
    dataset = services_of(client).apps["census"].datasets.current(services_of(client).db)
    for tract in dataset.tracts[:10]:
        open_balloon(client, tract.geoid)
    open_balloon(client, dataset.tracts[9].geoid)
    balloons = state_of(client).balloons
    assert len(balloons) == 8 and balloons[-1].id == f"tract-{dataset.tracts[9].geoid}"
    assert len({b.id for b in balloons}) == 8


def test_tract_pages_follow_the_readers_class(client: TestClient) -> None:
    show_census(client)
    register_student(client)
    url = "/apps/census/demo/tracts/06061022001/here"
    student = client.get(url).text
    assert len(re.findall(r"<tr>", student)) == 4
    assert "Population under 16" not in student and "Total population" in student
    client.post(
        "/me", data={"user_group": "undergraduate", "info_class": 3, "csrf": csrf_of(client)}
    )
    wider = client.get(url).text
    assert "Population under 16" in wider and "Workers 16 and over" not in wider
    assert "Employed civilians 16 and over" not in wider
    with TestClient(client.app) as instructor:  # a phone of its own: class 5 by default
        sign_in(instructor, "instructor")
        everything = instructor.get(url).text
    assert len(re.findall(r"<tr>", everything)) == 27


def test_tract_pages_show_margins_of_error_by_class(client: TestClient, tmp_path: Path) -> None:
    """An ACS data set: class 1 reads which values are uncertain, class 2 their margins
    too, class 4 and up each margin's share of its value; a bound reads as one."""
    import_files(
        services_of(client).db,
        shapes=write_shapefile(tmp_path / "tracts"),
        key="GEOID",
        tables=downloaded(tmp_path, INCOME, VALUE),
    )
    show_census(client)
    register_student(client)
    url = "/apps/census/demo/tracts/06067000100/here"

    def row(page: str, label: str) -> list[str]:
        match = re.search(rf"<th scope=\"row\">{re.escape(label)}</th><td>(.*?)</td>", page)
        assert match, f"no row {label!r}"
        return re.sub(r"<[^>]+>", " ", match.group(1)).split()

    income = "Median household income in the past 12 months (in 2022 inflation-adjusted dollars)"
    child = client.get(url).text
    assert row(child, income) == ["$52,941", "uncertain"]
    assert row(child, "Median value (dollars)") == ["$412,300"]
    assert "±" not in child and "rough figure" in child
    client.post(
        "/me", data={"user_group": "undergraduate", "info_class": 2, "csrf": csrf_of(client)}
    )
    student = client.get(url).text
    assert row(student, income) == ["$52,941", "±", "$6,123", "uncertain"]
    assert row(student, "Median value (dollars)") == ["$412,300", "±", "$35,120"]
    assert "90% confidence" in student and "as Census Reporter does" in student
    with TestClient(client.app) as instructor:
        sign_in(instructor, "instructor")
        expert = instructor.get(url).text
        bound = instructor.get("/apps/census/demo/tracts/06067000200/here").text
    assert row(expert, income) == ["$52,941", "±", "$6,123", "(12%)", "uncertain"]
    assert row(bound, income) == ["$250,000", "or", "more"]


def test_a_student_cannot_read_above_their_ceiling(client: TestClient) -> None:
    show_census(client)
    register_student(client)
    response = client.post(
        "/me", data={"user_group": "undergraduate", "info_class": 5, "csrf": csrf_of(client)}
    )
    assert response.status_code in (200, 400)
    page = client.get("/apps/census/demo/tracts/06061022001/here").text
    assert "Employed civilians 16 and over" not in page, "students stop at class 3"


def test_scanning_a_tract_offers_the_wall_or_the_phone(client: TestClient) -> None:
    show_census(client)
    change(client, {"view": {"center": [0.5, 0.5], "zoom": 4}})
    codes = census_codes(client)
    name = next(n for n in codes if n.startswith("census:tract:"))
    page = client.get(f"/t/{codes[name]}").text
    assert "Show on the wall" in page and "Show here" in page


def test_publishing_a_tract_page(client: TestClient) -> None:
    show_census(client)
    register_student(client)
    page = client.get("/apps/census/demo/tracts/06061022001/here").text
    code = re.search(r'name="code" value="([^"]+)"', page)
    subject = re.search(r'name="subject" value="([^"]+)"', page)
    assert code and subject and subject.group(1) == "06061022001"
    response = client.post(
        "/publish",
        data={"code": code.group(1), "subject": subject.group(1), "csrf": csrf_of(client)},
    )
    assert response.status_code == 200
    item = state_of(client).public
    assert item is not None and item.title == "Tract 220.01, Placer"
    assert "$225,900" in item.html and "Population under 16" not in item.html
    # the charts the student's class sees on the phone go with it
    assert item.html.count("<svg ") == page.count("<svg ")


def test_the_index_lists_every_tract_by_group(client: TestClient) -> None:
    show_census(client)
    page = client.get("/apps/census/demo/tracts").text
    assert page.count("/apps/census/demo/tracts/06") == 403
    assert page.count('class="tract-group"') == 10


def test_the_index_names_tracts_by_their_name_and_counts_one_tract_as_one(
    client: TestClient, tmp_path: Path
) -> None:
    """Issue 31: a GeoJSON's text NAME was dropped, so the index read "Tract 3, 11001",
    and a group of one read "0003-0003 · 1 tracts"."""
    import_files(
        services_of(client).db,
        shapes=write_geojson(
            tmp_path / "dc.geojson",
            [
                (key, polygon(square(i)), {"ENROLL": 10 * (i + 1), "NAME": name})
                for i, (key, name) in enumerate(
                    zip(DC, ("Foggy Bottom", "Dupont", "Shaw"), strict=True)
                )
            ],
        ),
        key="GEOID",
    )
    show_census(client)
    page = client.get("/apps/census/demo/tracts").text
    assert ">Foggy Bottom</a>" in page and "Tract 3, 11001" not in page
    assert "<summary>0003 · 1 tract</summary>" in page and "1 tracts" not in page
    assert "3 tracts in 3 groups" in page


def test_pages_say_when_the_map_is_not_on_the_wall(client: TestClient) -> None:
    assert client.get("/apps/census/demo/tracts").status_code == 409
    show_census(client)
    assert client.get("/apps/census/demo/tracts/0000").status_code == 404
    assert client.get("/apps/census/nowall/tracts").status_code == 404
    change(client, {"app": "pattern"})
    page = client.get("/apps/census/demo/tracts/06061022001")
    assert page.status_code == 409 and "not on" in page.text
    assert census_codes(client) == {}, "its codes are off while the map is"


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


def test_google_earth_gets_the_wall_as_it_is(client: TestClient) -> None:
    from tests.webapp.apps.census_map.kml_schema import assert_valid_kml

    show_census(client)
    codes = census_codes(client)
    group = next(n for n in codes if n.startswith("census:group:")).removeprefix("census:group:")
    client.get(f"/t/{codes[f'census:group:{group}']}")  # hide a group
    register_student(client)
    dataset = services_of(client).apps["census"].datasets.current(services_of(client).db)
    open_balloon(client, dataset.tracts[5].geoid)

    kml = client.get("/apps/census/census.kml?wall=demo")
    assert kml.status_code == 200
    assert kml.headers["content-type"].startswith("application/vnd.google-earth.kml+xml")
    assert_valid_kml(kml.content)
    text = kml.text
    assert text.count("<Placemark") == 403 and text.count("<Folder") == 10
    hidden = re.search(rf'<Folder id="group-{group}">.*?<visibility>(\d)</visibility>', text, re.S)
    assert hidden and hidden.group(1) == "0"
    assert text.count("<gx:balloonVisibility>1</gx:balloonVisibility>") == 1

    kmz = client.get("/apps/census/census.kmz?wall=demo")
    assert kmz.status_code == 200 and kmz.content[:2] == b"PK"
    link = client.get("/apps/census/network-link.kml?wall=demo")
    assert_valid_kml(link.content)
    assert "/apps/census/census.kmz?wall=demo" in link.text and "onInterval" in link.text
    assert client.get("/apps/census/census.kml?wall=nope").status_code == 404


def test_kml_before_any_data_set_is_imported(client: TestClient) -> None:
    response = client.get("/apps/census/census.kml")
    assert response.status_code == 404 and "No census data set" in response.text


def test_a_new_phone_can_open_a_balloon_from_the_index(client: TestClient) -> None:
    show_census(client)
    page = client.get("/apps/census/demo/tracts/06061022001").text
    token = re.search(r'name="csrf" value="([^"]+)"', page)
    assert token, "the form carries the new visitor's token"
    response = client.post(
        "/apps/census/demo/tracts/06061022001/balloon", data={"csrf": token.group(1)}
    )
    assert response.status_code == 200 and [b.id for b in state_of(client).balloons] == [
        "tract-06061022001"
    ]


def test_the_index_switches_groups_too(client: TestClient) -> None:
    show_census(client)
    page = client.get("/apps/census/demo/tracts").text
    assert page.count("Hide them on the wall") == 10
    token = re.search(r'name="csrf" value="([^"]+)"', page)
    action = re.search(r'action="(/apps/census/demo/groups/[^"]+/toggle)"', page)
    assert token and action
    client.post(action.group(1), data={"csrf": token.group(1)})
    assert "Show them on the wall" in client.get("/apps/census/demo/tracts").text


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


def test_a_tract_page_says_where_it_stands_and_an_instructor_can_colour_from_it(
    client: TestClient,
) -> None:
    show_census(client)
    register_student(client)
    url = "/apps/census/demo/tracts/06061022001/here"
    assert 'id="standing"' not in client.get(url).text, "nothing to say on a plain map"
    colour(client, INCOME_THEME)
    student = client.get(url).text
    assert 'id="standing"' in student and "colour group" in student
    assert 'id="colour-wall"' not in student, "only instructors colour the wall"
    refused = client.post(
        "/apps/census/demo/theme",
        data={"attribute": "TOT_POP", "csrf": csrf_of(client)},
        follow_redirects=False,
    )
    assert refused.status_code == 303 and refused.headers["location"].startswith("/login")
    assert (
        CensusState.of(state_of(client)).theme is not None
        and CensusState.of(state_of(client)).theme.attribute == "HH_INC"
    )

    with TestClient(client.app) as instructor:
        sign_in(instructor, "instructor")
        page = instructor.get(url).text
        assert 'id="colour-wall"' in page and "Rank " in page
        token = re.search(r'name="csrf" value="([^"]+)"', page)
        assert token
        answer = instructor.post(
            "/apps/census/demo/theme",
            data={"attribute": "TOT_POP", "tract": "06061022001", "csrf": token.group(1)},
        )
        assert answer.status_code == 200 and "Total population" in answer.text
        assert answer.text.count('class="swatch"') == 6
        assert "/apps/census/demo/tracts/06061022001/here" in answer.text
        theme = CensusState.of(state_of(client)).theme
        assert theme is not None and theme.attribute == "TOT_POP"
        assert (theme.scheme, theme.method, theme.classes) == ("YlGnBu", "natural", 6), "kept"
        missing = instructor.post(
            "/apps/census/demo/theme", data={"attribute": "NOPE", "csrf": token.group(1)}
        )
        assert missing.status_code == 404
        plain = instructor.post("/apps/census/demo/theme", data={"csrf": token.group(1)})
        assert plain.status_code == 200 and "One plain colour" in plain.text
    assert CensusState.of(state_of(client)).theme is None


def test_google_earth_gets_the_wall_s_colours(client: TestClient) -> None:
    from tests.webapp.apps.census_map.kml_schema import assert_valid_kml

    show_census(client)
    colour(client, {**INCOME_THEME, "attribute": "HSG_VAL"})
    kml = client.get("/apps/census/census.kml?wall=demo")
    assert_valid_kml(kml.content)
    styles = re.findall(r"<styleUrl>#(style-[a-z0-9-]+)</styleUrl>", kml.text)
    assert len(styles) == 403 and "style-tract" not in styles
    assert styles.count("style-class-6") == 3, "the three tracts without a value: grey"
    assert len(set(styles)) == 7
    assert "Coloured by Median housing value" in kml.text
    colour(client, None)
    plain = client.get("/apps/census/census.kml?wall=demo").text
    assert plain.count("<styleUrl>#style-tract</styleUrl>") == 403


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
