"""The video store: every video an instructor added, as the file itself and what ffprobe
said of it.

One folder per video under ``var/videos/{id}``: ``manifest.json`` (what the wall and the
dashboard know of it) and ``video.mp4`` or ``video.webm``, the file as it came: browsers
play it as it is, so nothing is transcoded. A folder is filled under a hidden temporary
name and renamed into place only when complete, so a failed or interrupted add leaves
nothing a reader can take for a video, and a stored video never changes (tiles keep it
in their cache for good). A removal is the same in reverse: the folder leaves its place
under a hidden name in one rename, then goes.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from pydantic import BaseModel, Field

from webapp.apps.video.probe import Probed, VideoRefused, probe

MAX_VIDEO_TITLE = 200
MANIFEST = "manifest.json"
BUILDING = ".building-"  # the prefix of a folder being filled (never listed)
UPLOADING = ".upload-"  # the prefix of an upload's copy, moved into a folder or removed
REMOVING = ".removing-"  # the prefix of a removed video's folder, deleted right after
STALE_S = 6 * 3600  # an add, copy or removal this old was cut short (a killed server): swept
MEDIA_TYPES = {"mp4": "video/mp4", "webm": "video/webm"}
_ID = re.compile(r"^[0-9a-f]{12}$")


class VideoManifest(BaseModel):
    """What the wall and the dashboard know of a stored video."""

    id: str
    title: str = Field(max_length=MAX_VIDEO_TITLE)
    source: str  # the file name it was added as
    container: str  # "mp4" or "webm"
    video_codec: str
    audio_codec: str | None  # None: no sound
    width: int
    height: int
    fps: float
    duration_s: float
    bytes: int

    @property
    def file_name(self) -> str:
        """The stored file's name in its folder, and in its URL."""
        return f"video.{self.container}"

    @property
    def media_type(self) -> str:
        return MEDIA_TYPES[self.container]


@dataclass
class VideoStore:
    """The stored videos under ``root`` (``var/videos``), taken within the limits."""

    root: Path
    max_bytes: int
    max_duration_s: float

    def probe(self, source: Path, name: str) -> Probed:
        """What the file at ``source`` is, if a browser plays it within the limits;
        :class:`VideoRefused` with one line starting with ``name`` if not."""
        try:
            return probe(source, self.max_bytes, self.max_duration_s)
        except VideoRefused as error:
            raise VideoRefused(f"{name} {error}.") from None

    def add(
        self, source: Path, title: str | None = None, name: str | None = None, move: bool = False
    ) -> VideoManifest:
        """Store the video in ``source`` (``name``: the file name it came as), refused
        as :meth:`probe` refuses it, leaving nothing behind. ``move``: the file is an
        upload's copy beside the store, moved rather than copied. Blocking (ffprobe, a
        copy of up to gigabytes), so servers call it through ``run_blocking``."""
        name = name or source.name
        probed = self.probe(source, name)
        video_id = uuid.uuid4().hex[:12]
        self.root.mkdir(parents=True, exist_ok=True)
        self.sweep()
        manifest = VideoManifest(
            id=video_id,
            title=(title or Path(name).stem).strip()[:MAX_VIDEO_TITLE] or video_id,
            source=name,
            bytes=source.stat().st_size,
            container=probed.container,
            video_codec=probed.video_codec,
            audio_codec=probed.audio_codec,
            width=probed.width,
            height=probed.height,
            fps=probed.fps,
            duration_s=probed.duration_s,
        )
        building = self.root / f"{BUILDING}{video_id}"
        building.mkdir()
        try:
            target = building / manifest.file_name
            if move:
                os.replace(source, target)
            else:
                shutil.copyfile(source, target)
            (building / MANIFEST).write_text(manifest.model_dump_json(indent=2))
            building.rename(self.root / video_id)
        except BaseException:
            shutil.rmtree(building, ignore_errors=True)
            raise
        return manifest

    def sweep(self, now: float | None = None) -> list[Path]:
        """Remove what an add, upload or removal cut short by a killed server left
        (hidden, never listed, but taking disk), once it is :data:`STALE_S` old: one
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

    def videos(self) -> list[VideoManifest]:
        """Every stored video, newest first (a folder being filled is not one yet)."""
        found = []
        for folder in self.root.glob("*/"):
            if not _ID.match(folder.name):
                continue
            try:
                found.append(((folder / MANIFEST).stat().st_mtime, self.get(folder.name)))
            except (FileNotFoundError, KeyError):  # removed as this listed
                continue
        return [manifest for _, manifest in sorted(found, key=lambda f: -f[0])]

    def get(self, video_id: str) -> VideoManifest:
        """The manifest of ``video_id``; KeyError when there is no such video."""
        if not _ID.match(video_id):
            raise KeyError(video_id)
        try:
            text = (self.root / video_id / MANIFEST).read_text()
        except (FileNotFoundError, NotADirectoryError):
            raise KeyError(video_id) from None
        return VideoManifest.model_validate(json.loads(text))

    def holds(self, video_id: str) -> bool:
        """Whether ``video_id`` is a stored video (not one removed since it was chosen)."""
        try:
            self.get(video_id)
        except KeyError:
            return False
        return True

    def file(self, video_id: str, file_name: str) -> tuple[Path, VideoManifest]:
        """The stored file of ``video_id`` by its name in the URL, with its manifest;
        KeyError for any other name or video."""
        manifest = self.get(video_id)
        if file_name != manifest.file_name:
            raise KeyError(file_name)
        return self.root / video_id / file_name, manifest

    def remove(self, video_id: str) -> VideoManifest:
        """Remove the video (KeyError: no such video), never half: one rename takes the
        folder out of the list and off the tiles' route, then it is deleted. Whether a
        wall still shows it is the caller's question."""
        manifest = self.get(video_id)
        leaving = self.root / f"{REMOVING}{video_id}-{uuid.uuid4().hex[:8]}"
        try:
            (self.root / video_id).rename(leaving)
        except FileNotFoundError:  # removed meanwhile
            raise KeyError(video_id) from None
        shutil.rmtree(leaving, ignore_errors=True)
        return manifest
