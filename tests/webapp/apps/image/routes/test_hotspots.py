"""Hotspots through the API (``routes/hotspots``): instructors mark them (CSRF,
validated, nothing stored on error) and the wall carries a code at each."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.conftest import csrf_of, sign_in
from tests.webapp.apps.image.samples import NUCLEUS, hotspot_codes, shown_image


def test_instructors_add_edit_and_delete_hotspots_and_bad_input_is_refused(
    client: TestClient,
) -> None:
    image = shown_image(client)
    url = f"/api/apps/image/images/{image}/hotspots"
    assert client.post(url, json=NUCLEUS).status_code == 401
    sign_in(client, "instructor")
    assert client.post(url, json=NUCLEUS).status_code == 403  # no CSRF token
    csrf = {"X-CSRF-Token": csrf_of(client)}
    for body, message in [
        ({**NUCLEUS, "x": 601}, "(601, 100) is outside the image (600 x 400 px)."),
        ({**NUCLEUS, "accepted": []}, "A question needs at least one accepted answer."),
    ]:
        refused = client.post(url, json=body, headers=csrf)
        assert (refused.status_code, refused.json()["detail"]) == (422, message)
    assert client.post(url, json={**NUCLEUS, "title": "x" * 121}, headers=csrf).status_code == 422
    assert client.get(url).json() == []  # nothing stored
    assert hotspot_codes(client) == {}

    added = client.post(url, json=NUCLEUS, headers=csrf)
    assert added.status_code == 201, added.text
    spot = added.json()
    assert client.get(url).json() == [spot]
    assert set(hotspot_codes(client)) == {spot["id"]}  # its code is on the wall at once

    moved = client.put(f"{url}/{spot['id']}", json={**NUCLEUS, "x": 10}, headers=csrf)
    assert moved.status_code == 200 and moved.json()["x"] == 10
    refused = client.put(f"{url}/{spot['id']}", json={**NUCLEUS, "y": 401}, headers=csrf)
    assert refused.status_code == 422 and client.get(url).json()[0]["y"] == 100
    assert client.put(f"{url}/{'f' * 12}", json=NUCLEUS, headers=csrf).status_code == 404
    assert client.post(f"/api/apps/image/images/{'f' * 12}/hotspots", json=NUCLEUS, headers=csrf)\
        .status_code == 404  # fmt: skip

    deleted = client.delete(f"{url}/{spot['id']}", headers=csrf)
    assert deleted.status_code == 200 and deleted.json() == []
    assert client.get(url).json() == [] and hotspot_codes(client) == {}
