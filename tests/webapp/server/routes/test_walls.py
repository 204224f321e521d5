import pytest
from fastapi.testclient import TestClient

from tests.conftest import operator_headers as operator


@pytest.mark.walls("demo", "hiperwall", "irregular", "kl-3x3")
def test_lists_configured_walls(client: TestClient) -> None:
    walls = {w["id"]: w for w in client.get("/api/walls").json()}
    assert {"demo", "kl-3x3", "hiperwall", "irregular"} <= walls.keys()
    assert len(walls["demo"]["displays"]) == 6
    assert len(walls["hiperwall"]["displays"]) == 50


def test_wall_layout_includes_roles_and_viewports(client: TestClient) -> None:
    wall = client.get("/api/walls/demo").json()
    roles = {d["id"]: d["roles"] for d in wall["displays"]}
    assert "registration" in roles["r2c1"]
    assert "public" in roles["r1c2"]
    first = wall["displays"][0]
    assert len(first["scene_rect"]) == 4 and len(first["to_wall"]) == 6


def test_unknown_wall_is_404_json(client: TestClient) -> None:
    response = client.get("/api/walls/nowhere")
    assert response.status_code == 404
    assert "nowhere" in response.json()["detail"]


def test_status_and_changes_need_the_operator_token(client: TestClient) -> None:
    assert client.get("/api/walls/demo/status").status_code == 401
    bad = {"Authorization": "Bearer wrong"}
    assert client.get("/api/walls/demo/status", headers=bad).status_code == 401
    assert client.post("/api/walls/demo/state", json={"mode": "x"}).status_code == 401
    assert client.post("/api/walls/demo/state", json={"mode": "x"}, headers=bad).status_code == 401
    tile = {"Authorization": "Bearer " + client.app.state.services.tile_token("demo")}  # type: ignore[attr-defined]
    assert client.post("/api/walls/demo/state", json={"mode": "x"}, headers=tile).status_code == 401


def version_now(client: TestClient) -> int:
    """The wall's version (the app's start already put the wall's codes up)."""
    return int(client.get("/api/walls/demo/status", headers=operator(client)).json()["version"])


def test_state_change_round_trip(client: TestClient) -> None:
    start = version_now(client)
    response = client.post(
        "/api/walls/demo/state", json={"layers": {"grid": False}}, headers=operator(client)
    )
    assert response.json() == {"wall": "demo", "version": start + 1, "changed": ["layers"]}
    again = client.post(
        "/api/walls/demo/state", json={"layers": {"grid": False}}, headers=operator(client)
    )
    assert again.json() == {"wall": "demo", "version": start + 1, "changed": []}
    status = client.get("/api/walls/demo/status", headers=operator(client)).json()
    assert status["version"] == start + 1 and status["state"]["layers"] == {"grid": False}


def test_malformed_change_is_rejected_and_stores_nothing(client: TestClient) -> None:
    start = version_now(client)
    for body in ({"view": {"zoom": -1}}, {"unknown": 1}, {"layers": "all"}):
        response = client.post("/api/walls/demo/state", json=body, headers=operator(client))
        assert response.status_code == 422
        assert response.json()["detail"][0]["msg"]
    not_json = client.post(
        "/api/walls/demo/state",
        content=b"{oops",
        headers={**operator(client), "content-type": "application/json"},
    )
    assert not_json.status_code == 422
    assert version_now(client) == start


@pytest.mark.parametrize("field", ["view", "app", "mode", "balloons", "layers", "public_policy"])
def test_null_for_a_field_that_cannot_be_empty_is_422(client: TestClient, field: str) -> None:
    start = version_now(client)
    response = client.post("/api/walls/demo/state", json={field: None}, headers=operator(client))
    assert response.status_code == 422, response.text
    assert "may not be null" in response.text
    assert version_now(client) == start


@pytest.mark.parametrize("name", ["0", "core", "Brain"])
def test_an_app_that_is_not_one_is_422(client: TestClient, name: str) -> None:
    start = version_now(client)
    response = client.post("/api/walls/demo/state", json={"app": name}, headers=operator(client))
    assert response.status_code == 422, response.text
    assert "There is no app" in response.json()["detail"]
    assert version_now(client) == start


def test_null_volume_still_takes_the_volume_off(client: TestClient) -> None:
    response = client.post("/api/walls/demo/state", json={"volume": None}, headers=operator(client))
    assert response.status_code == 200


HUGE = "99999999999999999999999"


@pytest.mark.parametrize(
    "method,url,body",
    [
        ("GET", f"/api/walls/demo/layouts/{HUGE}", None),
        ("GET", f"/api/walls/demo/layouts/{2**31}", None),
        ("GET", f"/api/apps/census/walls/demo/tiles/r1c1?dataset={HUGE}", None),
        ("GET", f"/api/apps/census/walls/demo/tiles/r1c1?dataset=1&layout={HUGE}", None),
        ("GET", f"/api/apps/census/datasets/{HUGE}", None),
        ("POST", "/api/apps/census/current", {"dataset": int(HUGE)}),
        ("GET", f"/api/apps/brain/walls/demo/answers.csv?round={HUGE}", None),
        ("POST", f"/api/walls/demo/public/{HUGE}/approve", None),
    ],
)
def test_numbers_too_large_for_the_database_are_refused_not_500(
    client: TestClient, method: str, url: str, body: object
) -> None:
    """On SQLite and PostgreSQL alike, anonymously and as the operator."""
    for headers in ({}, operator(client)):
        response = client.request(method, url, json=body, headers=headers)
        assert response.status_code in (401, 404, 422), (headers, response.text)
    assert response.status_code == 422


def test_a_mode_goes_through_its_app_so_the_brain_closes_and_opens_its_rounds(
    client: TestClient,
) -> None:
    """{"mode": "tutor"} with the brain on the wall once left its round open, and every
    pin then answered 409: a mode is the app's setting, changed by the app's
    ``switch_mode`` whichever way it comes (here the state API)."""
    headers = operator(client)

    def post(patch: dict[str, object]) -> int:
        return client.post("/api/walls/demo/state", json=patch, headers=headers).status_code

    def brain() -> dict[str, object]:
        found: dict[str, object] = client.get("/api/apps/brain/walls/demo", headers=headers).json()
        return found

    assert post({"app": "brain"}) == 200
    first = brain()["round"]
    assert isinstance(first, dict) and first["open"]
    assert post({"mode": "tutor"}) == 200
    tutor = brain()
    assert tutor["mode"] == "tutor" and isinstance(tutor["round"], dict)
    assert not tutor["round"]["open"]  # tutor pages name every pin
    assert post({"mode": "quiz"}) == 200
    again = brain()["round"]
    assert isinstance(again, dict) and again["open"] and again["number"] == first["number"] + 1


def test_a_mode_the_app_does_not_have_is_refused_and_changes_nothing(client: TestClient) -> None:
    start = version_now(client)
    headers = operator(client)
    refused = client.post("/api/walls/demo/state", json={"mode": "karaoke"}, headers=headers)
    assert refused.status_code == 422
    assert refused.json()["detail"] == (
        "The pattern app has no mode 'karaoke' (its modes: default)."
    )
    both = client.post(
        "/api/walls/demo/state", json={"app": "census", "mode": "tutor"}, headers=headers
    )
    assert both.status_code == 422 and "The census app has no mode 'tutor'" in both.text
    assert version_now(client) == start
