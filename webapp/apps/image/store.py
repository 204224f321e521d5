"""The image store: every image an instructor added, as a Deep Zoom tile pyramid.

An image may be a phone photo or a 30,000 x 30,000 px scan, far more than fits in a
tile's memory or a request: libvips (:mod:`pyvips`) streams it once from the file
(``access="sequential"``) into a pyramid of 512 px JPEG tiles, level ``levels - 1`` the
full size and each level below half the one above, down to one pixel (Deep Zoom's
``{level}/{col}_{row}.jpg``). A tile of the wall then fetches only the pyramid tiles its
display shows, at the level of its own pixel density (``static/image.js``).

One folder per image under ``var/images/{id}``: ``manifest.json`` (what the wall needs to
know of it) and ``pyramid_files/``. A folder is built under a hidden temporary name and
renamed into place only when complete, so a failed or interrupted build leaves nothing a
reader can take for an image, and an image never changes once stored (its tiles are
cached for good; only its title may). A removal is the same in reverse: the folder
leaves its place under a hidden name in one rename, then goes.
"""

from __future__ import annotations

import fcntl
import importlib
import json
import math
import os
import re
import shutil
import time
import uuid
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from pydantic import BaseModel, Field

if TYPE_CHECKING:
    import pyvips

TILE_SIZE = 512
MAX_IMAGE_TITLE = 200
MAX_PIXELS = 1_200_000_000
"""Refused before decoding: a 30,000 x 30,000 px scan is 9e8 pixels; a file declaring
more is a mistake or a decompression bomb."""
MAX_UPLOAD_BYTES = 2_000_000_000
"""The largest upload taken (a 30,000 px square scan as a JPEG or compressed TIFF)."""
FORMATS = {
    b"\x89PNG\r\n\x1a\n": ("pngload", "PNG"),
    b"\xff\xd8\xff": ("jpegload", "JPEG"),
    b"II*\x00": ("tiffload", "TIFF"),  # little-endian
    b"MM\x00*": ("tiffload", "TIFF"),  # big-endian
    b"II+\x00": ("tiffload", "TIFF"),  # BigTIFF
    b"MM\x00+": ("tiffload", "TIFF"),
}
"""The formats taken, by their first bytes: the libvips loader that reads each, and its
name. A file is read by the loader its first bytes name, never by the one libvips
would guess: an SVG, PDF or PostScript file under an image's name reaches no decoder
(librsvg, poppler, ImageMagick parse whatever they are given)."""
TRUSTED_LOADERS = ("VipsForeignLoadPng", "VipsForeignLoadJpeg", "VipsForeignLoadTiff")
TILE_SUFFIX = ".jpg[Q=85,strip]"
PYRAMID = "pyramid"  # dzsave's base name: pyramid.dzi and pyramid_files/
MANIFEST = "manifest.json"
BUILDING = ".building-"  # the prefix of a folder being built (never listed)
UPLOADING = ".upload-"  # the prefix of an upload's copy, removed once stored or refused
REMOVING = ".removing-"  # the prefix of a removed image's folder, deleted right after
STALE_S = 6 * 3600  # a build, copy or removal this old was cut short (a killed server): swept
LOCK = ".lock"  # in an image's folder: its changes go one at a time
_ID = re.compile(r"^[0-9a-f]{12}$")


class ImageRefused(ValueError):
    """An input that is not stored; the message says why in one line."""


class NoLibvips(RuntimeError):
    """libvips is not installed: images cannot be added (those stored still show)."""


def _vips() -> ModuleType:
    """pyvips, imported when an image is added: a server without libvips still starts,
    serves the stored pyramids and says what to install when one is added.

    Every libvips loader but the three of :data:`FORMATS` is blocked for the process
    (and the operations libvips itself calls untrusted): whatever asks libvips to load
    a file here gets nothing from librsvg, poppler or ImageMagick. A libvips too old to
    block them adds nothing."""
    try:
        pyvips = importlib.import_module("pyvips")
    except (ImportError, OSError) as error:
        raise NoLibvips(f"libvips is not installed ({error}): apt-get install libvips42") from None
    if not pyvips.at_least_libvips(8, 13):
        raise NoLibvips(
            f"libvips 8.13 or later is needed to block the loaders uploads must not reach "
            f"(this is {pyvips.version(0)}.{pyvips.version(1)}): apt-get install libvips42"
        )
    pyvips.block_untrusted_set(True)
    pyvips.operation_block_set("VipsForeignLoad", True)
    for loader in TRUSTED_LOADERS:
        pyvips.operation_block_set(loader, False)
    return pyvips


class ImageManifest(BaseModel):
    """What the wall and the dashboard know of a stored image."""

    id: str
    title: str = Field(max_length=MAX_IMAGE_TITLE)
    width: int
    height: int
    tile_size: int
    levels: int  # Deep Zoom levels 0 (1 x 1 px) .. levels - 1 (full size)
    source: str  # the file name it was added from
    format: str  # PNG, JPEG or TIFF

    def level_size(self, level: int) -> tuple[int, int]:
        """The image's size in pixels at ``level``."""
        shrink = 1 << (self.levels - 1 - level)
        return math.ceil(self.width / shrink), math.ceil(self.height / shrink)

    def tile_grid(self, level: int) -> tuple[int, int]:
        """Columns and rows of tiles at ``level``."""
        width, height = self.level_size(level)
        return math.ceil(width / self.tile_size), math.ceil(height / self.tile_size)


def deep_zoom_levels(width: int, height: int) -> int:
    """How many levels Deep Zoom makes: halving down to one pixel."""
    return math.ceil(math.log2(max(width, height))) + 1


@dataclass
class ImageStore:
    """The stored images under ``root`` (``var/images``)."""

    root: Path
    max_pixels: int = MAX_PIXELS
    max_upload_bytes: int = MAX_UPLOAD_BYTES

    def add(
        self,
        source: Path,
        title: str | None = None,
        name: str | None = None,
        extras: Mapping[str, bytes] | None = None,
    ) -> ImageManifest:
        """Store the image in ``source`` (``name``: the file name it came as); raise
        :class:`ImageRefused` for anything that is not a whole PNG, JPEG or TIFF within
        the pixel limit, leaving nothing behind. ``extras`` are files written into the
        image's folder before it is renamed into place (an imported lesson's hotspots),
        so the image never shows without them. Blocking: seconds to minutes for a
        scan, so servers call it through ``run_blocking``."""
        name = name or source.name
        image, kind = self._open(source, name)
        image_id = uuid.uuid4().hex[:12]
        self.root.mkdir(parents=True, exist_ok=True)
        self.sweep()
        building = self.root / f"{BUILDING}{image_id}"
        building.mkdir()
        try:
            _pyramid(image, building / PYRAMID, name)
            manifest = ImageManifest(
                id=image_id,
                title=(title or Path(name).stem).strip()[:MAX_IMAGE_TITLE] or image_id,
                width=image.width,
                height=image.height,
                tile_size=TILE_SIZE,
                levels=deep_zoom_levels(image.width, image.height),
                source=name,
                format=kind,
            )
            (building / MANIFEST).write_text(manifest.model_dump_json(indent=2))
            for file_name, data in (extras or {}).items():
                (building / file_name).write_bytes(data)
            building.rename(self.root / image_id)
        except BaseException:
            shutil.rmtree(building, ignore_errors=True)
            raise
        return manifest

    def probe(self, source: Path, name: str) -> tuple[int, int, str]:
        """Width, height and format of the image in ``source``, refused as :meth:`add`
        refuses it (from the header: nothing decoded), for a check before storing."""
        image, kind = self._open(source, name)
        return image.width, image.height, kind

    def _open(self, source: Path, name: str) -> tuple[pyvips.Image, str]:
        """The image's header (nothing decoded yet) and its format, if it is one we take,
        read by that format's own loader."""
        if source.stat().st_size == 0:
            raise ImageRefused(f"{name} is empty.")
        with source.open("rb") as file:
            start = file.read(8)
        found = next((f for magic, f in FORMATS.items() if start.startswith(magic)), None)
        if found is None:
            raise ImageRefused(f"{name} is not a PNG, JPEG or TIFF image.")
        loader, kind = found
        pyvips = _vips()
        try:
            image = getattr(pyvips.Image, loader)(
                str(source), access="sequential", fail_on="truncated"
            )
        except pyvips.Error:
            raise ImageRefused(f"{name} is not a PNG, JPEG or TIFF image.") from None
        pixels = image.width * image.height
        if pixels == 0:
            raise ImageRefused(f"{name} has no pixels ({image.width} x {image.height}).")
        if pixels > self.max_pixels:
            raise ImageRefused(
                f"{name} declares {image.width} x {image.height} px ({pixels:.3g} pixels), "
                f"more than the {self.max_pixels:.3g} taken."
            )
        return image, kind

    def sweep(self, now: float | None = None) -> list[Path]:
        """Remove what a build, upload or removal cut short by a killed server left
        (hidden, never listed, but taking disk), once it is :data:`STALE_S` old: a build
        still running is younger. Returns what was removed."""
        cutoff = (time.time() if now is None else now) - STALE_S
        removed = []
        for left in self.root.glob(".*"):
            hidden = left.name.startswith((BUILDING, UPLOADING, REMOVING))
            if hidden and left.stat().st_mtime < cutoff:
                if left.is_dir():
                    shutil.rmtree(left, ignore_errors=True)
                else:
                    left.unlink(missing_ok=True)
                removed.append(left)
        return removed

    def images(self) -> list[ImageManifest]:
        """Every stored image, newest first (a folder being built is not one yet); by
        its manifest's time, which never changes (the folder's does as hotspots are
        stored in it)."""
        found = []
        for folder in self.root.glob("*/"):
            if not _ID.match(folder.name):
                continue
            try:
                found.append(((folder / MANIFEST).stat().st_mtime, self.get(folder.name)))
            except (FileNotFoundError, KeyError):  # removed as this listed
                continue
        return [manifest for _, manifest in sorted(found, key=lambda f: -f[0])]

    def get(self, image_id: str) -> ImageManifest:
        """The manifest of ``image_id``; KeyError when there is no such image."""
        if not _ID.match(image_id):
            raise KeyError(image_id)
        try:
            text = (self.root / image_id / MANIFEST).read_text()
        except (FileNotFoundError, NotADirectoryError):
            raise KeyError(image_id) from None
        return ImageManifest.model_validate(json.loads(text))

    def holds(self, image_id: str) -> bool:
        """Whether ``image_id`` is a stored image (not one removed since it was chosen)."""
        try:
            self.get(image_id)
        except KeyError:
            return False
        return True

    @contextmanager
    def locked(self, image_id: str) -> Iterator[ImageManifest]:
        """One change of an image's folder at a time (its hotspots, its title, its
        removal), across threads and a server's worker processes alike: an exclusive
        lock on a file of the folder, released as it closes. Yields the manifest as it
        is once the lock is held; KeyError when there is no such image, or it was
        removed while this waited."""
        self.get(image_id)  # a known id before any path is made of it
        try:
            handle = (self.root / image_id / LOCK).open("a")
        except FileNotFoundError:  # removed since
            raise KeyError(image_id) from None
        with handle:
            fcntl.flock(handle, fcntl.LOCK_EX)
            yield self.get(image_id)

    def retitle(self, image_id: str, title: str) -> ImageManifest:
        """Give the image another title (KeyError: no such image); its manifest keeps
        its time, so the list keeps its order."""
        with self.locked(image_id) as manifest:
            path = self.root / image_id / MANIFEST
            renamed = ImageManifest.model_validate({**manifest.model_dump(), "title": title})
            write_whole(path, renamed.model_dump_json(indent=2).encode(), path.stat().st_mtime_ns)
        return renamed

    def remove(self, image_id: str) -> ImageManifest:
        """Remove the image, its pyramid and hotspots (KeyError: no such image), never
        half: one rename takes the folder out of the list and off the tile routes, then
        it is deleted; what a killed server leaves of it is swept like a cut-short
        build. Whether a wall still shows it is the caller's question."""
        with self.locked(image_id) as manifest:
            leaving = self.root / f"{REMOVING}{image_id}-{uuid.uuid4().hex[:8]}"
            (self.root / image_id).rename(leaving)
        shutil.rmtree(leaving, ignore_errors=True)
        return manifest

    def tile(self, image_id: str, level: int, col: int, row: int) -> Path:
        """The file of one pyramid tile; KeyError when there is none. A wall's displays
        ask for hundreds at each view change, so this is one look at the disk (the
        pyramid holds exactly its tiles; the manifest is not read)."""
        path = self.root / image_id / f"{PYRAMID}_files" / str(level) / f"{col}_{row}.jpg"
        if not (_ID.match(image_id) and min(level, col, row) >= 0 and path.is_file()):
            raise KeyError((image_id, level, col, row))
        return path

    def full_size(self, manifest: ImageManifest, target: Path) -> None:
        """Write the stored image at full size to ``target`` as a TIFF (no size limit,
        unlike JPEG's 65,535 px; JPEG-compressed like the tiles), joined from its finest
        level's tiles: the store keeps no original (a lesson's export needs one)."""
        pyvips = _vips()
        level = manifest.levels - 1
        cols, rows = manifest.tile_grid(level)
        folder = self.root / manifest.id / f"{PYRAMID}_files" / str(level)
        tiles = [
            pyvips.Image.new_from_file(str(folder / f"{col}_{row}.jpg"), access="sequential")
            for row in range(rows)
            for col in range(cols)
        ]
        # arrayjoin gives every cell the largest tile's size: the edge tiles are cut short
        joined = pyvips.Image.arrayjoin(tiles, across=cols).crop(
            0, 0, manifest.width, manifest.height
        )
        joined.tiffsave(str(target), compression="jpeg", Q=90, tile=True, bigtiff=True)


def write_whole(path: Path, data: bytes, mtime_ns: int | None = None) -> None:
    """Write ``path`` whole or not at all: to a hidden file beside it, renamed over it,
    so a reader never sees half of it (``mtime_ns``: the time it is to keep)."""
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex}")
    try:
        temporary.write_bytes(data)
        if mtime_ns is not None:
            os.utime(temporary, ns=(mtime_ns, mtime_ns))
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def _pyramid(image: pyvips.Image, base: Path, name: str) -> None:
    """Write the Deep Zoom pyramid of ``image`` at ``base`` in one streaming pass, as
    8-bit sRGB (alpha flattened on black, 16-bit and CMYK converted) in JPEG tiles."""
    if image.interpretation not in ("srgb", "b-w"):
        image = image.colourspace("srgb")
    if image.hasalpha():
        image = image.flatten(background=[0])
    if image.format != "uchar":
        image = image.cast("uchar")
    pyvips = _vips()
    try:
        image.dzsave(str(base), tile_size=TILE_SIZE, overlap=0, suffix=TILE_SUFFIX, layout="dz")
    except pyvips.Error as error:
        reason = str(error).strip().splitlines()[-1].strip()
        raise ImageRefused(f"{name} is damaged or truncated ({reason}).") from None
