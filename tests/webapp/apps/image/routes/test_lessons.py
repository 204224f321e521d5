"""Lessons through the API (``routes/lessons``): instructors export an image with its
hotspots and import a lesson file, every damaged one answered with a 422 of one line."""

from __future__ import annotations

import io
import json
import zipfile

from fastapi.testclient import TestClient
from PIL import Image

from tests.conftest import csrf_of, operator_headers, sign_in
from tests.webapp.apps.image.lessons import HANDMADE, changed
from tests.webapp.apps.image.samples import NUCLEUS, png_bytes, stored_folders, upload


def test_the_api_answers_each_damaged_zip_with_a_422_of_one_line(client: TestClient) -> None:
    sign_in(client, "instructor")
    csrf = {"X-CSRF-Token": csrf_of(client)}
    before = stored_folders(client)
    for case, made, line in HANDMADE:
        files = {"file": ("cell.tagwall-lesson", made(), "application/zip")}
        refused = client.post("/api/apps/image/lessons", files=files, headers=csrf)
        assert (refused.status_code, refused.json()["detail"]) == (422, line), case
    assert stored_folders(client) == before


def test_instructors_export_and_import_a_lesson_through_the_api(client: TestClient) -> None:
    operator = operator_headers(client)
    image = upload(client, png_bytes(), **operator).json()["id"]
    client.post(f"/api/apps/image/images/{image}/hotspots", json=NUCLEUS, headers=operator)
    assert client.get(f"/api/apps/image/images/{image}/lesson").status_code == 401

    exported = client.get(f"/api/apps/image/images/{image}/lesson", headers=operator)
    assert exported.status_code == 200, exported.text
    assert exported.headers["content-disposition"] == 'attachment; filename="scan.tagwall-lesson"'
    with zipfile.ZipFile(io.BytesIO(exported.content)) as archive:
        assert json.loads(archive.read("lesson.json"))["hotspots"][0]["title"] == "Nucleus"
        with Image.open(io.BytesIO(archive.read("image.tif"))) as picture:
            assert picture.size == (600, 400)
    assert (
        client.get("/api/apps/image/images/0123456789ab/lesson", headers=operator).status_code
        == 404
    )

    def send(data: bytes, **headers: str):  # type: ignore[no-untyped-def]
        files = {"file": ("cell.tagwall-lesson", data, "application/zip")}
        return client.post("/api/apps/image/lessons", files=files, headers=headers)

    before = stored_folders(client)
    assert send(exported.content).status_code == 401
    sign_in(client, "instructor")
    assert send(exported.content).status_code == 403  # no CSRF header
    csrf = {"X-CSRF-Token": csrf_of(client)}
    missing = io.BytesIO()
    with zipfile.ZipFile(missing, "w") as out:
        out.writestr("lesson.json", changed())
    refused = send(missing.getvalue(), **csrf)
    assert refused.status_code == 422
    assert refused.json()["detail"] == "cell.tagwall-lesson: the image 'cell.png' is missing."
    assert stored_folders(client) == before

    imported = send(exported.content, **csrf)
    assert imported.status_code == 201, imported.text
    copy = imported.json()
    assert (copy["title"], copy["width"], copy["height"]) == ("Scan", 600, 400)
    assert copy["id"] != image
    spots = client.get(f"/api/apps/image/images/{copy['id']}/hotspots").json()
    assert [(s["title"], s["accepted"]) for s in spots] == [("Nucleus", NUCLEUS["accepted"])]
    assert len(stored_folders(client)) == len(before) + 1  # no upload copy left behind
