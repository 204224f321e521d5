"""The tags API: issuing every payload kind, tag sets, layouts tiles fetch."""

from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.conftest import operator_headers


def issue(client: TestClient, wall: str = "demo", **spec: Any) -> Any:
    body = {"app": "pattern", "action": "locate", "anchor": [600, 300], **spec}
    return client.post(f"/api/walls/{wall}/tags", json=body, headers=operator_headers(client))


def test_tags_api_needs_the_operator(client: TestClient) -> None:
    assert client.get("/api/walls/demo/tags").status_code == 401
    body = {"app": "pattern", "action": "locate", "anchor": [1, 1]}
    assert client.post("/api/walls/demo/tags", json=body).status_code == 401
    assert client.put("/api/walls/demo/tag-set", json={"name": None}).status_code == 401
    assert client.get("/api/walls/demo/tag-sets").status_code == 401


@pytest.mark.parametrize(
    ("spec", "payload_start"),
    [
        ({"kind": "url"}, "HTTP://192.168.1.20:8000/T/"),
        ({"kind": "text", "text": "Exit is behind you"}, "Exit is behind you"),
        ({"kind": "tel", "number": "+1 555 0100"}, "tel:+15550100"),
        ({"kind": "vcard", "contact": {"name": "Front desk", "phone": "+1555"}}, "BEGIN:VCARD"),
    ],
)
def test_issue_each_payload_kind(
    client: TestClient, spec: dict[str, Any], payload_start: str
) -> None:
    response = issue(client, label="x", tag_set="setup", **spec)
    assert response.status_code == 201, response.text
    tag = response.json()
    assert tag["payload"].startswith(payload_start)
    assert tag["created_by"] == "operator"
    listed = client.get("/api/walls/demo/tags", headers=operator_headers(client)).json()
    assert tag["code"] in {t["code"] for t in listed}


def test_a_new_tag_in_the_active_set_is_placed_on_the_wall(client: TestClient) -> None:
    before = client.get("/api/walls/demo/tag-sets", headers=operator_headers(client)).json()
    tag = issue(client, label="new", tag_set="setup", anchor=[2000, 1000]).json()
    after = client.get("/api/walls/demo/tag-sets", headers=operator_headers(client)).json()
    assert after["layout"] != before["layout"]
    assert after["placed"] == before["placed"] + 1
    layout = client.get(f"/api/walls/demo/layouts/{after['layout']}").json()
    assert tag["code"] in {p["code"] for p in layout["placed"]}


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ({"anchor": None}, "either an anchor"),
        ({"screen": "menu"}, "either an anchor"),
        ({"kind": "text", "text": ""}, "needs some text"),
        ({"kind": "text", "text": "naïve"}, "ASCII"),
        ({"kind": "tel", "number": "call me"}, "phone number"),
        ({"kind": "bogus"}, "kind"),
        ({"tag_set": "bad set!"}, "tag_set"),
        ({"screen": "lobby", "anchor": None}, "screen"),
        ({"size_mm": -3}, "size_mm"),
    ],
)
def test_bad_tags_are_refused_and_nothing_is_stored(
    client: TestClient, spec: dict[str, Any], fragment: str
) -> None:
    before = client.get("/api/walls/demo/tags", headers=operator_headers(client)).json()
    response = issue(client, **spec)
    assert response.status_code == 422
    assert fragment in response.text
    after = client.get("/api/walls/demo/tags", headers=operator_headers(client)).json()
    assert after == before


def test_a_tag_of_an_app_not_installed_is_refused_and_nothing_is_stored(
    client: TestClient,
) -> None:
    """A scan goes to the tag's app: a tag of no installed app could never answer one."""
    before = client.get("/api/walls/demo/tags", headers=operator_headers(client)).json()
    response = issue(client, app="custom")
    assert response.status_code == 422
    assert "There is no app 'custom' (installed: brain, census, core, " in response.text
    after = client.get("/api/walls/demo/tags", headers=operator_headers(client)).json()
    assert after == before
    # the registration codes' app is installed: an extra student code is one of its tags
    extra = issue(client, app="core", action="register", params={"role": "student"})
    assert extra.status_code == 201, extra.text


def test_unknown_wall_and_tag(client: TestClient) -> None:
    assert issue(client, wall="nowhere").status_code == 404
    headers = operator_headers(client)
    assert client.get("/api/tags/ZZZZZZZ", headers=headers).status_code == 404
    assert client.patch("/api/tags/bad!", json={}, headers=headers).status_code == 404
    assert client.patch("/api/tags/ZZZZZZZ", json={"color": 1}, headers=headers).status_code == 422


def test_switching_tag_sets(client: TestClient) -> None:
    headers = operator_headers(client)
    info = client.get("/api/walls/demo/tag-sets", headers=headers).json()
    assert info["active"] == "setup" and "setup" in info["sets"]
    issue(client, label="quiz", tag_set="quiz", anchor=[100, 100])
    switched = client.put("/api/walls/demo/tag-set", json={"name": "quiz"}, headers=headers)
    assert switched.status_code == 200
    assert switched.json()["active"] == "quiz"
    assert switched.json()["placed"] == 3  # two registration codes and the quiz code
    status = client.get("/api/walls/demo/status", headers=headers).json()
    assert status["state"]["tag_set"] == "quiz"
    assert status["state"]["tag_layout"] == switched.json()["layout"]
    back = client.put("/api/walls/demo/tag-set", json={"name": "setup"}, headers=headers).json()
    assert back["layout"] == info["layout"]  # same inputs: the earlier layout is reused
    unknown = client.put("/api/walls/demo/tag-set", json={"name": "nope"}, headers=headers)
    assert unknown.status_code == 404 and "setup" in unknown.json()["detail"]


@pytest.mark.walls("demo", "hiperwall")  # a layout is not another wall's
def test_layouts_are_public_immutable_and_filter_by_display(client: TestClient) -> None:
    layout_id = client.get("/api/walls/demo/tag-sets", headers=operator_headers(client)).json()[
        "layout"
    ]
    response = client.get(f"/api/walls/demo/layouts/{layout_id}")
    assert response.status_code == 200
    assert "immutable" in response.headers["cache-control"]
    placed = response.json()["placed"]
    registration = [p for p in placed if p["display"] == "r2c1"]
    assert sorted(p["label"] for p in registration) == ["Instructor", "Student"]
    only = client.get(f"/api/walls/demo/layouts/{layout_id}?display=r2c1").json()["placed"]
    assert only == registration
    code = registration[0]
    assert code["px_per_module"] >= 3 and len(code["matrix"]) == 25
    assert code["payload"].startswith("HTTP://192.168.1.20:8000/T/")
    assert client.get("/api/walls/demo/layouts/999999").status_code == 404
    assert client.get(f"/api/walls/hiperwall/layouts/{layout_id}").status_code == 404
