"""A lesson to share: an image with its hotspots exported as one file and imported on
another installation (CLI and API), and every bad lesson file refused with its line and
nothing stored."""

from __future__ import annotations

import io
import json
import struct
import zipfile
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient
from PIL import Image

from tests.conftest import csrf_of, operator_headers, sign_in
from tests.webapp.apps.image.test_hotspot_routes import NUCLEUS, WALL_TEXT
from tests.webapp.apps.image.test_routes import png_bytes, stored_folders, upload
from webapp.apps.image import hotspots
from webapp.apps.image.hotspots import HotspotFields
from webapp.apps.image.lesson import LessonRefused, import_lesson
from webapp.apps.image.store import ImageStore
from webapp.cli.commands import main

LESSON: dict[str, Any] = {
    "version": 1,
    "title": "Cell",
    "image": {"file": "cell.png", "width": 600, "height": 400, "format": "PNG"},
    "hotspots": [NUCLEUS, WALL_TEXT],
}


def lesson_zip(path: Path, members: dict[str, bytes]) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as out:
        for name, data in members.items():
            out.writestr(name, data)
    return path


def changed(**fields: Any) -> bytes:
    return json.dumps({**LESSON, **fields}).encode()


def spot(**fields: Any) -> dict[str, Any]:
    return {**NUCLEUS, **fields}


GOOD = {"lesson.json": changed(), "cell.png": png_bytes()}
BAD: list[tuple[str, dict[str, bytes], str]] = [
    (
        "missing image",
        {"lesson.json": changed()},
        "cell.tagwall-lesson: the image 'cell.png' is missing.",
    ),
    ("no lesson.json", {"cell.png": png_bytes()}, "cell.tagwall-lesson: no lesson.json in it."),
    (
        "newer version",
        {**GOOD, "lesson.json": changed(version=2)},
        "lesson.json: format version 2; this installation reads 1.",
    ),
    (
        "not an image",
        {**GOOD, "cell.png": b"not a picture"},
        "cell.png is not a PNG, JPEG or TIFF image.",
    ),
    (
        "outside",
        {**GOOD, "lesson.json": changed(hotspots=[spot(x=601)])},
        "lesson.json: hotspot 1 ('Nucleus'): (601, 100) is outside the image (600 x 400 px).",
    ),
    (
        "no accepted answer",
        {**GOOD, "lesson.json": changed(hotspots=[WALL_TEXT, spot(accepted=[])])},
        "lesson.json: hotspot 2 ('Nucleus'): A question needs at least one accepted answer.",
    ),
    (
        "zip-slip",
        {**GOOD, "../evil.txt": b"x"},
        "cell.tagwall-lesson: unsafe path '../evil.txt'.",
    ),
    (
        "bomb",
        {**GOOD, "zeros.bin": bytes(6_000_000)},
        "cell.tagwall-lesson: unpacks to 6 MB, more than the 5 MB taken.",
    ),
    (
        "wrong size",
        {"lesson.json": changed(hotspots=[NUCLEUS]), "cell.png": png_bytes(300, 200)},
        "cell.png: 300 x 200 px, but lesson.json says 600 x 400 px.",
    ),
    (
        "bad field",
        {**GOOD, "lesson.json": changed(title="")},
        "lesson.json: title: String should have at least 1 character.",
    ),
]


@pytest.mark.parametrize(("case", "members", "line"), BAD, ids=[b[0] for b in BAD])
def test_a_bad_lesson_is_refused_with_its_line_and_nothing_stored(
    tmp_path: Path, case: str, members: dict[str, bytes], line: str
) -> None:
    store = ImageStore(tmp_path / "images", max_upload_bytes=100_000)
    source = lesson_zip(tmp_path / "cell.tagwall-lesson", members)
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert refused.value.problems == [line]
    assert list(store.root.iterdir()) == []
    assert not (tmp_path / "evil.txt").exists()


# Offsets of a member's fields in its local header and in its central directory entry
# (APPNOTE 4.3.7 and 4.3.12), to make by hand the ZIPs no writer makes.
LOCAL_VERSION, CENTRAL_VERSION = 4, 6  # the version needed to extract
LOCAL_FLAGS, CENTRAL_FLAGS = 6, 8
LOCAL_METHOD, CENTRAL_METHOD = 8, 10
LOCAL_SIZE, CENTRAL_SIZE = 22, 24  # the uncompressed size


def patched(data: bytes, member: str, local: int, central: int, value: int, size: int) -> bytes:
    """``data`` (a ZIP) with one field of ``member`` set to ``value`` in its local header
    and in its central directory entry (found from the end of central directory)."""
    out = bytearray(data)
    fmt = {2: "<H", 4: "<I"}[size]
    end = out.rindex(b"PK\x05\x06")
    entry = struct.unpack_from("<I", out, end + 16)[0]
    while True:
        name, extra, comment = struct.unpack_from("<HHH", out, entry + 28)
        if out[entry + 46 : entry + 46 + name] == member.encode():
            break
        entry += 46 + name + extra + comment
    struct.pack_into(fmt, out, struct.unpack_from("<I", out, entry + 42)[0] + local, value)
    struct.pack_into(fmt, out, entry + central, value)
    return bytes(out)


def zipped(members: dict[str, bytes], method: int = zipfile.ZIP_DEFLATED) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", method) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return out.getvalue()


def bad_crc() -> bytes:
    """The picture stored with one byte changed after its checksum was taken."""
    data = bytearray(zipped(GOOD, zipfile.ZIP_STORED))
    with zipfile.ZipFile(io.BytesIO(bytes(data))) as archive:
        info = archive.getinfo("cell.png")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    data[start + 100] ^= 0xFF
    return bytes(data)


def encrypted() -> bytes:
    return patched(zipped(GOOD), "cell.png", LOCAL_FLAGS, CENTRAL_FLAGS, 1, 2)


def deflate64() -> bytes:
    """Method 9 (Deflate64: Windows' Explorer writes it for large files), which Python
    does not read."""
    return patched(zipped(GOOD), "cell.png", LOCAL_METHOD, CENTRAL_METHOD, 9, 2)


def strongly_encrypted() -> bytes:
    return patched(zipped(GOOD), "cell.png", LOCAL_FLAGS, CENTRAL_FLAGS, 0x40, 2)


def patched_data() -> bytes:
    """Flag bit 5, compressed patched data (a ZIP 2.7 feature Python does not read)."""
    return patched(zipped(GOOD), "cell.png", LOCAL_FLAGS, CENTRAL_FLAGS, 0x20, 2)


def newer_version() -> bytes:
    """A member needing a ZIP reader of version 9.9 to extract it."""
    return patched(zipped(GOOD), "cell.png", LOCAL_VERSION, CENTRAL_VERSION, 99, 2)


def lying_bomb() -> bytes:
    """A picture declaring 1,000 bytes that inflates to 50 MB (its checksum of the
    50 MB): the declared sizes pass, the data does not."""
    members = {**GOOD, "cell.png": png_bytes()[:16] + bytes(50_000_000)}
    return patched(zipped(members), "cell.png", LOCAL_SIZE, CENTRAL_SIZE, 1_000, 4)


def no_directory() -> bytes:
    """The end record is there, the central directory it points at is not."""
    data = zipped(GOOD)
    return data.replace(b"PK\x01\x02", b"PK\x00\x00")


def nested() -> bytes:
    return zipped({**GOOD, "lesson.json": b"[" * 100_000 + b"]" * 100_000})


HANDMADE: list[tuple[str, Any, str]] = [
    (
        "bad CRC",
        bad_crc,
        "cell.tagwall-lesson: 'cell.png' is damaged: its data does not match the "
        "ZIP's checksum or size.",
    ),
    (
        "encrypted",
        encrypted,
        "cell.tagwall-lesson: 'cell.png' is encrypted; a lesson file is not.",
    ),
    (
        "strongly encrypted",
        strongly_encrypted,
        "cell.tagwall-lesson: 'cell.png' is encrypted; a lesson file is not.",
    ),
    (
        "patched data",
        patched_data,
        "cell.tagwall-lesson: 'cell.png' uses compressed patched data (flag bit 5), which "
        "a lesson file does not.",
    ),
    (
        "newer version",
        newer_version,
        "cell.tagwall-lesson: a ZIP of a kind a lesson file is not (zip file version 9.9).",
    ),
    (
        "deflate64",
        deflate64,
        "cell.tagwall-lesson: 'cell.png' is compressed with deflate64; a lesson file "
        "uses store or deflate.",
    ),
    (
        "inflates past its size",
        lying_bomb,
        "cell.tagwall-lesson: 'cell.png' is damaged: its data does not match the "
        "ZIP's checksum or size.",
    ),
    (
        "no directory",
        no_directory,
        "cell.tagwall-lesson: a damaged ZIP file (its directory cannot be read).",
    ),
    ("nested 100,000 deep", nested, "lesson.json: nested too deeply to be a lesson."),
]


@pytest.mark.parametrize(("case", "made", "line"), HANDMADE, ids=[h[0] for h in HANDMADE])
def test_a_damaged_or_foreign_zip_is_refused_in_one_line(
    tmp_path: Path, case: str, made: Any, line: str
) -> None:
    """ZIPs no lesson export makes (each built byte by byte): refused before anything
    is stored, never more extracted than a member declares."""
    store = ImageStore(tmp_path / "images", max_upload_bytes=100_000)
    source = tmp_path / "cell.tagwall-lesson"
    source.write_bytes(made())
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert refused.value.problems == [line]
    assert list(store.root.iterdir()) == []


def test_the_api_answers_each_damaged_zip_with_a_422_of_one_line(client: TestClient) -> None:
    sign_in(client, "instructor")
    csrf = {"X-CSRF-Token": csrf_of(client)}
    before = stored_folders(client)
    for case, made, line in HANDMADE:
        files = {"file": ("cell.tagwall-lesson", made(), "application/zip")}
        refused = client.post("/api/apps/image/lessons", files=files, headers=csrf)
        assert (refused.status_code, refused.json()["detail"]) == (422, line), case
    assert stored_folders(client) == before


def test_not_a_zip_and_every_problem_of_a_file_on_a_line_of_its_own(tmp_path: Path) -> None:
    store = ImageStore(tmp_path / "images")
    notes = tmp_path / "notes.zip"
    notes.write_text("not a zip")
    with pytest.raises(LessonRefused, match=r"^notes.zip: not a ZIP file \(a lesson"):
        import_lesson(store, notes)
    both = [spot(x=-1), spot(question=None, accepted=["x"])]
    source = lesson_zip(tmp_path / "two.zip", {**GOOD, "lesson.json": changed(hotspots=both)})
    with pytest.raises(LessonRefused) as refused:
        import_lesson(store, source)
    assert len(refused.value.problems) == 2
    assert "Accepted answers need a question." in refused.value.problems[1]


def test_export_then_import_on_a_fresh_installation_with_the_cli(tmp_path: Path) -> None:
    runner = CliRunner()
    here = {"TAGWALL_VAR_DIR": str(tmp_path / "here")}
    there = {"TAGWALL_VAR_DIR": str(tmp_path / "there")}
    source = tmp_path / "cell.png"
    source.write_bytes(png_bytes())
    assert (
        runner.invoke(main, ["image", "add", str(source), "--title", "Cell"], env=here).exit_code
        == 0
    )
    store = ImageStore(tmp_path / "here" / "images")
    image_id = store.images()[0].id
    for fields in (NUCLEUS, WALL_TEXT):
        hotspots.add(store, image_id, HotspotFields.model_validate(fields))

    lesson = tmp_path / "cell.tagwall-lesson"
    exported = runner.invoke(main, ["image", "export", image_id, str(lesson)], env=here)
    assert exported.exit_code == 0, exported.output
    checked = runner.invoke(main, ["image", "check", str(lesson)], env=there)
    assert checked.stdout == "ok: 'Cell', 600 x 400 px, 2 hotspots, 1 questions\n"
    imported = runner.invoke(main, ["image", "import", str(lesson)], env=there)
    assert imported.exit_code == 0, imported.output
    assert "'Cell', 600 x 400 px, 2 hotspots" in imported.stdout

    fresh = ImageStore(tmp_path / "there" / "images")
    [manifest] = fresh.images()
    assert (manifest.width, manifest.height, manifest.title) == (600, 400, "Cell")
    strip = [s.model_dump(exclude={"id"}) for s in hotspots.hotspots(store, image_id)]
    assert [s.model_dump(exclude={"id"}) for s in hotspots.hotspots(fresh, manifest.id)] == strip

    bad = lesson_zip(tmp_path / "bad.zip", {"lesson.json": changed()})
    for command in ("check", "import"):
        refused = runner.invoke(main, ["image", command, str(bad)], env=there)
        assert refused.exit_code == 2
        assert refused.stderr.splitlines() == [
            "bad.zip: the image 'cell.png' is missing.",
            "1 problem(s) found",
        ]
    assert len(fresh.images()) == 1
    missing = runner.invoke(main, ["image", "export", "0123456789ab", str(lesson)], env=here)
    assert missing.exit_code == 2 and "There is no image 0123456789ab." in missing.stderr


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
