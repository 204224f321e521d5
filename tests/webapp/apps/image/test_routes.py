"""The image app's API: upload (instructors, CSRF), list, show, retitle, remove, manifest
and tiles."""

from __future__ import annotations

import io
from pathlib import Path

from fastapi.testclient import TestClient
from PIL import Image

from tests.conftest import csrf_of, operator_headers, services_of, sign_in
from tests.webapp.apps.image.samples import FOREIGN, png_declaring, quadrants
from webapp.apps.image.app import ImageApp
from webapp.apps.image.state import ImageState
from webapp.engine.wall_state import read_state


def png_bytes(width: int = 600, height: int = 400) -> bytes:
    out = io.BytesIO()
    Image.fromarray(quadrants(width, height)).save(out, format="PNG")
    return out.getvalue()


def image_app(client: TestClient) -> ImageApp:
    app = services_of(client).apps["image"]
    assert isinstance(app, ImageApp)
    return app


def stored_folders(client: TestClient) -> list[Path]:
    root = image_app(client).store(services_of(client).settings).root
    return sorted(root.iterdir()) if root.exists() else []


def upload(client: TestClient, data: bytes, name: str = "scan.png", **headers: str):  # type: ignore[no-untyped-def]
    return client.post(
        "/api/apps/image/images",
        files={"file": (name, data, "image/png")},
        data={"title": "Scan"},
        headers=headers,
    )


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


def test_only_instructors_upload_list_and_show(client: TestClient) -> None:
    assert upload(client, png_bytes()).status_code == 401
    assert client.get("/api/apps/image/images").status_code == 401
    assert client.post("/api/apps/image/walls/demo/show", json={"image": "x"}).status_code == 401
    operator = operator_headers(client)
    assert upload(client, png_bytes(), **operator).status_code == 201
    unknown = client.post(
        "/api/apps/image/walls/demo/show", json={"image": "0123456789ab"}, headers=operator
    )
    assert unknown.status_code == 404


BAD_UPLOADS = [
    (png_bytes()[:900], "half.png", 422, "half.png is damaged or truncated"),
    (b"hello" * 100, "notes.png", 422, "notes.png is not a PNG, JPEG or TIFF image"),
    *(
        (data, name, 422, f"{name} is not a PNG, JPEG or TIFF image")
        for name, data in FOREIGN.items()
    ),
    (b"", "empty.png", 422, "empty.png is empty"),
    (None, "bomb.png", 422, "declares 100000 x 100000 px"),
    (None, "zero.png", 422, "zero.png"),
    (b"\0" * 300_000, "huge.png", 413, "larger than 0.2 MB"),
]


def test_a_bad_upload_gets_its_status_and_one_line_and_nothing_is_kept(
    client: TestClient, tmp_path: Path
) -> None:
    image_app(client).max_upload_bytes = 200_000
    for data, name, status, detail in BAD_UPLOADS:
        if data is None:
            size = (100_000, 100_000) if name == "bomb.png" else (0, 0)
            data = png_declaring(tmp_path / name, *size).read_bytes()
        response = upload(client, data, name, **operator_headers(client))
        assert response.status_code == status, (name, response.text)
        said = response.json()["detail"]
        assert detail in said and "\n" not in said, said
        assert stored_folders(client) == [], name  # no orphan pyramid, no upload copy


def test_an_upload_without_a_file_or_a_length_is_refused(client: TestClient) -> None:
    operator = operator_headers(client)
    response = client.post("/api/apps/image/images", data={"title": "nothing"}, headers=operator)
    assert response.status_code == 400
    chunked = client.post(
        "/api/apps/image/images",
        content=iter([b"--x\r\n"]),
        headers={**operator, "Content-Type": "multipart/form-data; boundary=x"},
    )
    assert chunked.status_code == 411, chunked.text


def test_an_instructor_retitles_and_removes_an_image_but_not_one_on_a_wall(
    client: TestClient,
) -> None:
    operator = operator_headers(client)
    older = upload(client, png_bytes(), **operator).json()["id"]
    newer = upload(client, png_bytes(), **operator).json()["id"]
    client.post(
        f"/api/apps/image/images/{older}/hotspots",
        json={"x": 10, "y": 10, "title": "Corner"},
        headers=operator,
    )
    client.post("/api/apps/image/walls/demo/show", json={"image": older}, headers=operator)
    url = f"/api/apps/image/images/{older}"
    assert client.patch(url, json={"title": "Kidney"}).status_code == 401
    assert client.delete(url).status_code == 401
    sign_in(client, "instructor")
    assert client.patch(url, json={"title": "Kidney"}).status_code == 403  # no CSRF token
    assert client.delete(url).status_code == 403
    csrf = {"X-CSRF-Token": csrf_of(client)}

    renamed = client.patch(url, json={"title": "  Kidney, H&E "}, headers=csrf)
    assert renamed.status_code == 200 and renamed.json()["title"] == "Kidney, H&E"
    listed = client.get("/api/apps/image/images").json()
    assert [(i["id"], i["title"]) for i in listed] == [(newer, "Scan"), (older, "Kidney, H&E")]
    for title in ("", "   ", "x" * 201):
        assert client.patch(url, json={"title": title}, headers=csrf).status_code == 422, title
    assert client.get(f"/apps/image/images/{older}/info.json").json()["title"] == "Kidney, H&E"
    assert client.patch(f"/api/apps/image/images/{'f' * 12}", json={"title": "x"}, headers=csrf)\
        .status_code == 404  # fmt: skip

    shown = client.delete(url, headers=csrf)
    assert shown.status_code == 409
    assert shown.json()["detail"] == (
        "'Kidney, H&E' is shown on Demo wall (3 x 2, 55-inch): show another image there first."
    )
    assert client.delete(f"/api/apps/image/images/{'f' * 12}", headers=csrf).status_code == 404
    client.post("/api/apps/image/walls/demo/show", json={"image": newer}, headers=csrf)
    removed = client.delete(url, headers=csrf)
    assert removed.status_code == 200, removed.text
    assert [i["id"] for i in removed.json()] == [newer]
    assert [p.name for p in stored_folders(client)] == [newer]  # nothing left, nothing hidden
    assert client.get(f"{url}/hotspots").status_code == 404
    assert client.get(f"/apps/image/images/{older}/info.json").status_code == 404
    assert client.delete(url, headers=csrf).status_code == 404


def test_a_wall_back_on_the_image_app_shows_the_newest_when_its_image_was_removed(
    client: TestClient,
) -> None:
    operator = operator_headers(client)
    older = upload(client, png_bytes(), **operator).json()["id"]
    newer = upload(client, png_bytes(), **operator).json()["id"]
    client.post("/api/apps/image/walls/demo/show", json={"image": older}, headers=operator)
    away = client.post("/api/walls/demo/state", json={"app": "pattern"}, headers=operator)
    assert away.status_code == 200, away.text
    # the demo wall keeps its choice in the slot but shows nothing of it: removable
    assert client.delete(f"/api/apps/image/images/{older}", headers=operator).status_code == 200
    back = client.post("/api/walls/demo/state", json={"app": "image"}, headers=operator)
    assert back.status_code == 200, back.text
    _, state = read_state(services_of(client).db, "demo")
    assert ImageState.of(state).image == newer
