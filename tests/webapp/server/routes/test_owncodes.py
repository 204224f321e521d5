"""An instructor's own codes over HTTP: added at a point of the wall or at a place of the
material the wall shows (a hotspot of the image, which the code follows), placed,
scanned, listed and switched off."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.conftest import operator_headers, services_of
from tests.webapp.apps.image.samples import NUCLEUS, shown_image
from webapp.engine.wall_state import read_state
from webapp.tags.registry import get_layout


def add(client: TestClient, **code: Any) -> Any:
    return client.post("/api/walls/demo/own-codes", json=code, headers=operator_headers(client))


def placed(client: TestClient) -> dict[str, dict[str, Any]]:
    db = services_of(client).db
    layout = get_layout(db, "demo", read_state(db, "demo")[1].tag_layout)
    assert layout is not None
    return {p["code"]: p for p in layout.placed}


def test_a_link_stands_where_it_was_put_and_opens_its_page(client: TestClient) -> None:
    response = add(
        client,
        kind="link",
        label="Reading list",
        url="https://example.org/a?b=1",
        anchor=[600, 500],
    )

    assert response.status_code == 201, response.text
    code = response.json()
    assert code["app"] == "core" and code["action"] == "link" and code["tag_set"] is None
    assert code["code"] in placed(client)
    scanned = client.get(f"/t/{code['code']}", follow_redirects=False)
    assert scanned.status_code == 303
    assert scanned.headers["location"] == "https://example.org/a?b=1"


def test_direct_codes_carry_their_content(client: TestClient) -> None:
    text = add(client, kind="text", label="Note", text="Bring gloves", anchor=[300, 300]).json()
    phone = add(client, kind="phone", label="Lab", number="+1 916 555 0100", anchor=[900, 300])
    contact = add(
        client,
        kind="contact",
        label="Dr Ann",
        contact={"name": "Ann Lee", "email": "ann@example.org"},
        anchor=[1500, 300],
    )

    assert text["payload"] == "Bring gloves"
    assert phone.json()["payload"] == "tel:+19165550100"
    assert "FN:Ann Lee" in contact.json()["payload"]
    listed = client.get("/api/walls/demo/own-codes", headers=operator_headers(client)).json()
    assert [c["label"] for c in listed] == ["Dr Ann", "Lab", "Note"]


@pytest.mark.parametrize(
    ("code", "says"),
    [
        ({"kind": "link", "url": "javascript:alert(1)"}, "URL scheme should be 'http' or 'https'"),
        ({"kind": "link", "url": "ftp://example.org/x"}, "URL scheme should be 'http' or 'https'"),
        ({"kind": "link"}, "a link needs its url"),
        ({"kind": "text", "text": "ü" * 10}, "ASCII"),
        ({"kind": "phone", "number": "call me"}, "phone number"),
        ({"kind": "link", "url": "https://example.org", "anchor": [-5, 10]}, "off the wall"),
        ({"kind": "link", "url": "https://example.org", "anchor": [99_999, 10]}, "off the wall"),
        ({"kind": "link", "url": "https://example.org", "label": ""}, "at least 1 character"),
        ({"kind": "poster", "url": "https://example.org"}, ""),
    ],
)
def test_a_code_that_cannot_be_is_refused_and_nothing_is_stored(
    client: TestClient, code: dict[str, Any], says: str
) -> None:
    body = {"label": "X", "anchor": [600, 500], **code}
    response = add(client, **body)
    assert response.status_code == 422, response.text
    assert says in response.text
    assert client.get("/api/walls/demo/own-codes", headers=operator_headers(client)).json() == []


def test_switching_a_code_off_takes_it_off_the_wall(client: TestClient) -> None:
    code = add(client, kind="link", label="L", url="https://example.org", anchor=[600, 500]).json()

    off = client.patch(
        f"/api/tags/{code['code']}", json={"active": False}, headers=operator_headers(client)
    )

    assert off.status_code == 200
    assert code["code"] not in placed(client)
    assert client.get(f"/t/{code['code']}").status_code == 410
    listed = client.get("/api/walls/demo/own-codes", headers=operator_headers(client)).json()
    assert [c["active"] for c in listed] == [False]


def test_only_instructors_add_codes(client: TestClient) -> None:
    body = {"kind": "link", "label": "L", "url": "https://example.org", "anchor": [1, 1]}
    assert client.post("/api/walls/demo/own-codes", json=body).status_code == 401
    assert client.get("/api/walls/demo/own-codes").status_code == 401


def test_a_link_issued_raw_with_another_scheme_never_redirects(client: TestClient) -> None:
    raw = {"app": "core", "action": "link", "params": {"url": "javascript:x"}, "anchor": [600, 500]}
    tag = client.post("/api/walls/demo/tags", json=raw, headers=operator_headers(client)).json()
    scanned = client.get(f"/t/{tag['code']}", follow_redirects=False)
    assert scanned.status_code == 404 and "not a web address" in scanned.text


def hotspot_place(client: TestClient) -> dict[str, Any]:
    """The image app on the wall with one hotspot (Nucleus); its place on the wall."""
    image = shown_image(client)
    operator = operator_headers(client)
    spot = client.post(f"/api/apps/image/images/{image}/hotspots", json=NUCLEUS, headers=operator)
    [place] = client.get("/api/walls/demo/places", headers=operator).json()
    assert place["app"] == "image" and place["id"] == f"{image}/{spot.json()['id']}"
    return dict(place)


def listed(client: TestClient) -> list[dict[str, Any]]:
    return list(client.get("/api/walls/demo/own-codes", headers=operator_headers(client)).json())


def test_the_places_are_those_of_the_app_on_the_wall_for_instructors_only(
    client: TestClient,
) -> None:
    operator = operator_headers(client)
    assert client.get("/api/walls/demo/places", headers=operator).json() == []  # the pattern
    place = hotspot_place(client)
    assert place["label"] == "hotspot Nucleus" and place["clear_mm"] > 0
    assert client.get("/api/walls/demo/places").status_code == 401
    assert client.get("/api/walls/nowhere/places", headers=operator).status_code == 404


def test_a_code_at_a_hotspot_follows_it_and_leaves_and_comes_back_with_the_image(
    client: TestClient,
) -> None:
    place = hotspot_place(client)
    choice = {"app": place["app"], "id": place["id"]}
    added = add(client, kind="text", label="Hint", text="Look closer", place=choice)
    assert added.status_code == 201, added.text
    code = added.json()
    assert code["params"]["place"] == {**choice, "label": "hotspot Nucleus"}
    assert code["on_wall"] and listed(client)[0]["on_wall"]
    before = placed(client)[code["code"]]
    assert before["anchor"] == place["anchor"] and before["leader"], "beside it, on a pin"

    operator = operator_headers(client)
    panned = {"view": {"center": [0.45, 0.5], "zoom": 1.5}}
    assert client.post("/api/walls/demo/state", json=panned, headers=operator).status_code == 200
    [moved_place] = client.get("/api/walls/demo/places", headers=operator).json()
    after = placed(client)[code["code"]]
    assert after["anchor"] == moved_place["anchor"] != place["anchor"]
    assert after["rect"] != before["rect"]
    image, spot = place["id"].split("/")
    renamed = {**NUCLEUS, "title": "Core"}
    client.put(f"/api/apps/image/images/{image}/hotspots/{spot}", json=renamed, headers=operator)
    assert listed(client)[0]["params"]["place"]["label"] == "hotspot Core"

    away = {"view": {"center": [0.9, 0.9], "zoom": 4}}  # the hotspot out of view
    client.post("/api/walls/demo/state", json=away, headers=operator)
    assert client.get("/api/walls/demo/places", headers=operator).json() == []
    assert code["code"] not in placed(client)
    client.post("/api/walls/demo/state", json={"app": "pattern"}, headers=operator)
    assert code["code"] not in placed(client)
    assert listed(client)[0]["on_wall"] is False and listed(client)[0]["anchor"] is None
    client.post("/api/walls/demo/state", json={"app": "image"}, headers=operator)
    assert placed(client)[code["code"]]["anchor"] == place["anchor"], "back at the whole image"

    client.patch(f"/api/tags/{code['code']}", json={"active": False}, headers=operator)
    assert code["code"] not in placed(client)
    assert [(c["active"], c["on_wall"]) for c in listed(client)] == [(False, False)]


NOT_ONE_PLACE_NOW: list[tuple[dict[str, Any], str]] = [
    ({}, "either a point of the wall (anchor) or a place"),
    ({"anchor": [600, 500], "place": {"app": "image", "id": "x"}}, "either a point"),
    ({"place": {"app": "image", "id": "0" * 12 + "/" + "0" * 12}}, "not on the wall now"),
    ({"place": {"app": "image"}}, "Field required"),
    ({"place": "image:x/y"}, "valid dictionary"),
    ({"place": {"app": "image", "id": "x", "label": "Mine"}}, "Extra inputs"),
]


def test_a_code_needs_exactly_one_place_of_the_wall_now(client: TestClient) -> None:
    """(The test pattern on the wall has no places: none is on the wall now.) One client
    for every case: each is a request refused before anything is stored."""
    for where, says in NOT_ONE_PLACE_NOW:
        response = add(client, kind="text", label="Hint", text="Look closer", **where)
        assert response.status_code == 422 and says in response.text, (where, response.text)
    assert listed(client) == []
