"""What phones ask for of the census map and do (``routes/phones``): a tract's pages
by the reader's class, the index, a balloon clear of every code, a group toggled
from a scan or a page, an instructor's colouring from a tract page."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import shapely
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, register_student, services_of, sign_in
from tests.webapp.apps.census_map.test_acs import INCOME, VALUE, downloaded
from tests.webapp.apps.census_map.test_importer import (
    DC,
    polygon,
    square,
    write_geojson,
    write_shapefile,
)
from tests.webapp.apps.census_map.walls import (
    INCOME_THEME,
    assert_clear_of_every_code,
    census_codes,
    change,
    colour,
    open_balloon,
    show_census,
    state_of,
)
from webapp.apps.census_map.importer import import_files
from webapp.apps.census_map.mapview import projection, shown_area
from webapp.apps.census_map.state import CensusState
from webapp.engine.wall_state import View


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
