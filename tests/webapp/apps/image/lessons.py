"""Lesson files the image app's tests make: a good one, and each way one can be bad
(most built byte by byte, as no lesson export makes them)."""

from __future__ import annotations

import io
import json
import struct
import zipfile
from pathlib import Path
from typing import Any

from tests.webapp.apps.image.samples import NUCLEUS, WALL_TEXT, png_bytes

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
