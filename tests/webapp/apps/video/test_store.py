"""The video store: a video is stored whole or not at all, listed newest first, served by
its one file name, removed in one rename; what a killed server left is swept."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from tests.webapp.apps.video.conftest import Samples
from webapp.apps.video import store as storing
from webapp.apps.video.probe import VideoRefused
from webapp.apps.video.store import BUILDING, STALE_S, UPLOADING, VideoStore


def a_store(root: Path, max_bytes: int = 10_000_000) -> VideoStore:
    return VideoStore(root, max_bytes, 3 * 3600)


def test_a_video_is_stored_with_what_the_wall_needs_and_listed_newest_first(
    tmp_path: Path, video_sample: Samples
) -> None:
    store = a_store(tmp_path / "videos")
    first = store.add(video_sample("lecture.mp4"), "Heart valves")
    second = store.add(video_sample("lecture.webm"))
    assert (first.title, first.container, first.video_codec, first.audio_codec) == (
        "Heart valves", "mp4", "h264", "aac",
    )  # fmt: skip
    assert (second.title, second.file_name, second.media_type) == (
        "lecture", "video.webm", "video/webm",
    )  # fmt: skip
    assert first.bytes == video_sample("lecture.mp4").stat().st_size
    os.utime(store.root / first.id / "manifest.json", (1, 1))  # older than the second
    assert [v.id for v in store.videos()] == [second.id, first.id]
    path, manifest = store.file(first.id, "video.mp4")
    assert path.read_bytes() == video_sample("lecture.mp4").read_bytes()
    assert manifest == first == store.get(first.id)
    for name in ["video.webm", "manifest.json", "../manifest.json"]:
        with pytest.raises(KeyError):
            store.file(first.id, name)
    for bad in ["nothing", "0123456789ab", "../videos"]:
        assert not store.holds(bad)


def test_an_uploads_copy_is_moved_into_place_not_copied(
    tmp_path: Path, video_sample: Samples
) -> None:
    store = a_store(tmp_path / "videos")
    store.root.mkdir()
    copy = store.root / f"{UPLOADING}1234"
    copy.write_bytes(video_sample("silent.mp4").read_bytes())
    added = store.add(copy, None, "talk.mp4", move=True)
    assert not copy.exists() and added.title == "talk" and added.source == "talk.mp4"
    assert sorted(p.name for p in store.root.iterdir()) == [added.id]


def test_a_refused_or_failed_add_leaves_nothing(
    tmp_path: Path, video_sample: Samples, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = a_store(tmp_path / "videos")
    with pytest.raises(VideoRefused, match=r"^hevc\.mp4 is MP4 with H\.265 video.*\.$"):
        store.add(video_sample("hevc.mp4"))
    with pytest.raises(VideoRefused, match=r"^lecture\.mp4 is .* MB, more than the 0 MB taken"):
        a_store(tmp_path / "videos", max_bytes=100).add(video_sample("lecture.mp4"))

    def full(source: Path, target: Path) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(storing.shutil, "copyfile", full)
    with pytest.raises(OSError, match="No space"):
        store.add(video_sample("lecture.mp4"))
    assert list(store.root.iterdir()) == [] and store.videos() == []


def test_a_removal_takes_the_video_off_in_one_rename(tmp_path: Path, video_sample: Samples) -> None:
    store = a_store(tmp_path / "videos")
    added = store.add(video_sample("lecture.mp4"))
    assert store.remove(added.id) == added
    assert list(store.root.iterdir()) == [] and not store.holds(added.id)
    with pytest.raises(KeyError):
        store.remove(added.id)


def test_what_a_killed_server_left_is_swept_once_stale(tmp_path: Path) -> None:
    store = a_store(tmp_path / "videos")
    store.root.mkdir()
    old = store.root / f"{BUILDING}aaaa"
    old.mkdir()
    young = store.root / f"{UPLOADING}bbbb"
    young.write_bytes(b"x")
    os.utime(old, (time.time() - STALE_S - 10,) * 2)
    assert store.sweep() == [old]
    assert sorted(p.name for p in store.root.iterdir()) == [young.name]
