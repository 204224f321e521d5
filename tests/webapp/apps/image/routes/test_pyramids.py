"""What tiles fetch of an image (``routes/pyramids``): its manifest and the pyramid
tiles of their displays, once it is uploaded and shown."""

from __future__ import annotations

import io

from fastapi.testclient import TestClient
from PIL import Image

from tests.conftest import csrf_of, services_of, sign_in
from tests.webapp.apps.image.samples import png_bytes, upload
from webapp.apps.image.state import ImageState
from webapp.engine.wall_state import read_state


def test_an_instructor_uploads_shows_and_every_tile_fetches_the_pyramid(
    client: TestClient,
) -> None:
    sign_in(client, "instructor")
    csrf = csrf_of(client)
    assert upload(client, png_bytes()).status_code == 403  # no CSRF header
    added = upload(client, png_bytes(), **{"X-CSRF-Token": csrf})
    assert added.status_code == 201, added.text
    image = added.json()
    assert (image["title"], image["width"], image["height"], image["levels"]) == (
        "Scan",
        600,
        400,
        11,
    )
    assert [i["id"] for i in client.get("/api/apps/image/images").json()] == [image["id"]]

    shown = client.post(
        "/api/apps/image/walls/demo/show",
        json={"image": image["id"]},
        headers={"X-CSRF-Token": csrf},
    )
    assert shown.status_code == 200, shown.text
    _, state = read_state(services_of(client).db, "demo")
    assert state.app == "image" and ImageState.of(state).image == image["id"]

    client.cookies.clear()  # tiles and the overview need no session
    info = client.get(f"/apps/image/images/{image['id']}/info.json")
    assert info.json() == image
    tile = client.get(f"/apps/image/images/{image['id']}/10/1_0.jpg")
    assert tile.status_code == 200 and tile.headers["content-type"] == "image/jpeg"
    assert "immutable" in tile.headers["cache-control"]
    with Image.open(io.BytesIO(tile.content)) as picture:
        assert picture.size == (600 - 512, 400)
    for missing in [
        f"/apps/image/images/{image['id']}/10/2_0.jpg",
        f"/apps/image/images/{image['id']}/11/0_0.jpg",
        "/apps/image/images/0123456789ab/0/0_0.jpg",
        f"/apps/image/images/{image['id']}/x/0_0.jpg",
        f"/apps/image/images/{image['id']}/0/0_-1.jpg",
        "/apps/image/images/nothing/info.json",
    ]:
        assert client.get(missing).status_code == 404, missing
