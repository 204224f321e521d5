"""A lesson to share: an image with its hotspots (texts and questions) as one file, to
take from one installation to another (docs/image.md#sharing-a-lesson).

A lesson file is a ZIP holding ``lesson.json`` (:class:`Lesson`: the format version,
the title, the image's facts and the hotspots) and the image. The store keeps no
original, only the pyramid, so the image exported is its finest level reassembled
from the tiles (the full size; JPEG tiles at Q85, so not the original's bytes).

A lesson file comes from elsewhere, so everything in it is checked before anything is
stored, and every problem is said in one line (:func:`inspect`, shared by the import
and ``tagwall image check``): the ZIP's declared sizes before anything is extracted (a
ZIP bomb), its paths (a member named ``../x`` is never written anywhere), its members'
encryption and compression (only what an export writes: stored or deflated, never
encrypted), the data against its checksum as it is extracted (never more than a member
declares: a ZIP bomb lying about its size), the JSON (its depth too), the image as the
store checks an upload, and each hotspot with the same :func:`check` the API uses. An
import then stores the image and its hotspots together (:meth:`ImageStore.add`'s
``extras``): there is never an image without its hotspots, nor a lesson without its
image.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import uuid
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path, PurePosixPath

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from webapp.apps.image.hotspots import (
    HOTSPOTS,
    MAX_HOTSPOTS,
    Hotspot,
    HotspotFields,
    HotspotRefused,
    check,
    encoded,
    hotspots,
)
from webapp.apps.image.store import (
    MAX_IMAGE_TITLE,
    UPLOADING,
    ImageManifest,
    ImageRefused,
    ImageStore,
)

VERSION = 1
LESSON_JSON = "lesson.json"
IMAGE_FILE = "image.tif"  # the name an export gives the image (an import takes any)
SUFFIX = ".tagwall-lesson"
MAX_JSON_BYTES = 5_000_000  # 200 hotspots of 4 x 5,000 characters fit with room to spare
MAX_MEMBERS = 16
METHODS = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED)  # what an export writes
OTHER_METHODS = {9: "deflate64", 12: "bzip2", 14: "lzma", 93: "zstandard"}
"""Compressions met in ZIPs from elsewhere (Windows' Explorer writes deflate64 for large
files), by name in the line refusing them (APPNOTE 4.4.5)."""
ENCRYPTED = 0x41  # the general purpose flag's bits 0 and 6, strong encryption (APPNOTE 4.4.4)


class LessonRefused(ValueError):
    """A lesson file that is not imported: every problem, one line each."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


class LessonImage(BaseModel):
    """The image's facts: its file in the ZIP and what it must measure."""

    model_config = ConfigDict(extra="forbid")

    file: str = Field(min_length=1, max_length=200)
    width: int = Field(gt=0)
    height: int = Field(gt=0)
    format: str  # PNG, JPEG or TIFF, as the store found it
    source: str = ""  # the file name it was first added from


class Lesson(BaseModel):
    """``lesson.json``."""

    model_config = ConfigDict(extra="forbid")

    version: int
    title: str = Field(min_length=1, max_length=MAX_IMAGE_TITLE)
    image: LessonImage
    hotspots: list[HotspotFields] = Field(default_factory=list, max_length=MAX_HOTSPOTS)


def export(store: ImageStore, image_id: str, target: Path) -> Lesson:
    """Write the lesson of ``image_id`` to ``target`` (KeyError: no such image),
    whole or not at all: built beside it under a hidden name and renamed over it."""
    manifest = store.get(image_id)
    lesson = Lesson(
        version=VERSION,
        title=manifest.title,
        image=LessonImage(
            file=IMAGE_FILE,
            width=manifest.width,
            height=manifest.height,
            format=manifest.format,
            source=manifest.source,
        ),
        hotspots=[
            HotspotFields.model_validate(spot.model_dump(exclude={"id"}))
            for spot in hotspots(store, image_id)
        ],
    )
    partial = target.with_name(f".{target.name}.{uuid.uuid4().hex}")
    try:
        with tempfile.TemporaryDirectory(prefix="tagwall-lesson-") as scratch:
            image = Path(scratch) / IMAGE_FILE
            store.full_size(manifest, image)
            with zipfile.ZipFile(partial, "w") as out:
                out.writestr(LESSON_JSON, lesson.model_dump_json(indent=2), zipfile.ZIP_DEFLATED)
                out.write(image, IMAGE_FILE, zipfile.ZIP_STORED)  # already compressed
        os.replace(partial, target)
    finally:
        partial.unlink(missing_ok=True)
    return lesson


def _unsafe(name: str) -> bool:
    """A member name that could write outside a folder (zip-slip), on any system."""
    path = PurePosixPath(name.replace("\\", "/"))
    return path.is_absolute() or ".." in path.parts or ":" in name


def _member_problems(name: str, member: zipfile.ZipInfo) -> list[str]:
    """What makes a member one no lesson file holds, said before anything is read: a
    path outside the folder, encryption, a compression other than an export's."""
    problems = []
    if _unsafe(member.filename):
        problems.append(f"{name}: unsafe path {member.filename!r}.")
    if member.flag_bits & ENCRYPTED:
        problems.append(f"{name}: {member.filename!r} is encrypted; a lesson file is not.")
    if member.compress_type not in METHODS:
        method = OTHER_METHODS.get(member.compress_type, f"method {member.compress_type}")
        problems.append(
            f"{name}: {member.filename!r} is compressed with {method}; a lesson file uses "
            "store or deflate."
        )
    return problems


@contextmanager
def _unpacking(name: str, member: zipfile.ZipInfo) -> Iterator[None]:
    """Reading ``member``: data that does not match its checksum, or inflates past its
    declared size (zipfile stops there, and the checksum of what it read is wrong),
    is a damaged file, and a feature zipfile does not read one a lesson file does not
    use, each said in one line."""
    try:
        yield
    except (zipfile.BadZipFile, zlib.error, EOFError):
        raise LessonRefused(
            [
                f"{name}: {member.filename!r} is damaged: its data does not match the "
                "ZIP's checksum or size."
            ]
        ) from None
    except NotImplementedError as error:  # patched data: no lesson export writes it
        raise LessonRefused(
            [f"{name}: {member.filename!r} uses {error}, which a lesson file does not."]
        ) from None


def inspect(
    store: ImageStore, source: Path, scratch: Path, name: str | None = None
) -> tuple[Lesson, Path]:
    """Check the lesson file ``source`` (``name``: the file name it came as) and extract
    its image into ``scratch`` (a folder the caller removes): the lesson and the image's
    path. Raise :class:`LessonRefused` with every problem found; nothing is stored."""
    name = name or source.name
    if not zipfile.is_zipfile(source):
        raise LessonRefused([f"{name}: not a ZIP file (a lesson file is one)."])
    try:
        archive = zipfile.ZipFile(source)
    except zipfile.BadZipFile:  # an end record, but no directory to go with it
        raise LessonRefused(
            [f"{name}: a damaged ZIP file (its directory cannot be read)."]
        ) from None
    except NotImplementedError as error:  # a member needing a newer ZIP reader
        raise LessonRefused([f"{name}: a ZIP of a kind a lesson file is not ({error})."]) from None
    with archive:
        members = archive.infolist()
        problems = [line for m in members for line in _member_problems(name, m)]
        if len(members) > MAX_MEMBERS:
            problems.append(f"{name}: {len(members)} files, more than the {MAX_MEMBERS} taken.")
        declared = sum(m.file_size for m in members)  # before anything is extracted
        limit = store.max_upload_bytes + MAX_JSON_BYTES
        if declared > limit:
            problems.append(
                f"{name}: unpacks to {declared / 1e6:.0f} MB, more than the "
                f"{limit / 1e6:.0f} MB taken."
            )
        if problems:
            raise LessonRefused(problems)
        by_name = {m.filename: m for m in members}
        lesson = _lesson(name, archive, by_name.get(LESSON_JSON))
        member = by_name.get(lesson.image.file)
        if member is None or member.is_dir():
            raise LessonRefused([f"{name}: the image {lesson.image.file!r} is missing."])
        if member.file_size > store.max_upload_bytes:
            raise LessonRefused(
                [f"{name}: the image is larger than {store.max_upload_bytes / 1e6:g} MB."]
            )
        image = scratch / f"{UPLOADING}{uuid.uuid4().hex}"
        with _unpacking(name, member), archive.open(member) as packed, image.open("wb") as out:
            shutil.copyfileobj(packed, out)  # zipfile stops at the declared size
    return lesson, _check_image(store, lesson, image)


def _lesson(name: str, archive: zipfile.ZipFile, member: zipfile.ZipInfo | None) -> Lesson:
    """``lesson.json``, read and validated: its version first (a newer format is named
    as such, not as a list of fields), then one line per field in error."""
    if member is None:
        raise LessonRefused([f"{name}: no {LESSON_JSON} in it."])
    if member.file_size > MAX_JSON_BYTES:
        raise LessonRefused([f"{LESSON_JSON}: larger than {MAX_JSON_BYTES / 1e6:g} MB."])
    with _unpacking(name, member):
        text = archive.read(member)
    try:
        data = json.loads(text)
    except ValueError as error:  # not UTF-8 or not JSON
        raise LessonRefused([f"{LESSON_JSON}: not JSON ({error})."]) from None
    except RecursionError:  # [[[[...: JSON, but no lesson is more than a few levels deep
        raise LessonRefused([f"{LESSON_JSON}: nested too deeply to be a lesson."]) from None
    version = data.get("version") if isinstance(data, dict) else None
    if version != VERSION:
        raise LessonRefused(
            [f"{LESSON_JSON}: format version {version}; this installation reads {VERSION}."]
        )
    try:
        return Lesson.model_validate(data)
    except ValidationError as error:
        raise LessonRefused(
            [f"{LESSON_JSON}: {'.'.join(map(str, e['loc']))}: {e['msg']}." for e in error.errors()]
        ) from None


def _check_image(store: ImageStore, lesson: Lesson, image: Path) -> Path:
    """The image as the store checks an upload, its size as declared, and each hotspot
    with the API's :func:`check`: every problem, one line each."""
    try:
        width, height, kind = store.probe(image, lesson.image.file)
    except ImageRefused as error:
        raise LessonRefused([str(error)]) from None
    problems = []
    if (width, height) != (lesson.image.width, lesson.image.height):
        problems.append(
            f"{lesson.image.file}: {width} x {height} px, but {LESSON_JSON} says "
            f"{lesson.image.width} x {lesson.image.height} px."
        )
    measured = ImageManifest(
        id="",
        title=lesson.title,
        width=width,
        height=height,
        tile_size=0,
        levels=0,
        source=lesson.image.file,
        format=kind,
    )
    for number, spot in enumerate(lesson.hotspots, 1):
        try:
            check(spot, measured)
        except HotspotRefused as error:
            problems.append(f"{LESSON_JSON}: hotspot {number} ({spot.title!r}): {error}")
    if problems:
        raise LessonRefused(problems)
    return image


def import_lesson(
    store: ImageStore, source: Path, name: str | None = None
) -> tuple[ImageManifest, list[Hotspot]]:
    """Store the lesson in ``source`` as a new image with its hotspots (new ids), all
    or nothing; :class:`LessonRefused` with every problem, nothing stored."""
    store.root.mkdir(parents=True, exist_ok=True)
    scratch = store.root / f"{UPLOADING}{uuid.uuid4().hex}"  # swept if a kill leaves it
    scratch.mkdir()
    try:
        lesson, image = inspect(store, source, scratch, name)
        spots = [Hotspot(id=uuid.uuid4().hex[:12], **s.model_dump()) for s in lesson.hotspots]
        try:
            added = store.add(
                image,
                lesson.title,
                lesson.image.source or lesson.image.file,
                extras={HOTSPOTS: encoded(spots)},
            )
        except ImageRefused as error:
            raise LessonRefused([str(error)]) from None
        return added, spots
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
