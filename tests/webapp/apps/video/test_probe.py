"""ffprobe's word on a file, judged: what browsers play is taken with what the wall needs
to know of it, and every other kind of file is refused in one line saying why."""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import pytest

from tests.webapp.apps.video.conftest import Samples
from webapp.apps.video import probe as probing
from webapp.apps.video.probe import NoFfprobe, Probed, VideoRefused, judge, probe

BYTES = 10_000_000
HOURS_3 = 3 * 3600.0


@pytest.mark.parametrize(
    "name,expected",
    [
        ("lecture.mp4", Probed("mp4", "h264", "aac", 64, 36, 30.0, 1.0)),
        ("silent.mp4", Probed("mp4", "h264", None, 64, 36, 30.0, 1.0)),
        ("lecture.webm", Probed("webm", "vp9", "opus", 64, 36, 30.0, 1.0)),
    ],
)
def test_what_browsers_play_is_taken(video_sample: Samples, name: str, expected: Probed) -> None:
    found = probe(video_sample(name), BYTES, HOURS_3)
    assert found == Probed(**{**vars(expected), "duration_s": pytest.approx(1.0, abs=0.05)})


REFUSED = [
    ("hevc.mp4", "is MP4 with H.265 video, which browsers do not all play: MP4 takes H.264"),
    ("ten-bit.mp4", "has H.264 video in yuv420p10le pixels, which browsers do not decode"),
    ("old.mp4", "is MP4 with MPEG-4 Part 2 video"),
    ("lecture.avi", "is AVI (Audio Video Interleaved), not MP4 or WebM"),
    ("h264.mkv", "is WebM with H.264 video, which browsers do not all play: WebM takes VP8"),
    ("ac3.mp4", "has AC-3 sound, which browsers do not play in MP4: MP4 takes AAC (or no sound)"),
    ("talk.m4a", "has no video stream (AAC sound only)"),
    ("four-hours.mp4", "lasts 4 h 0 min, longer than the 3 h 0 min taken"),
]


@pytest.mark.parametrize("name,said", REFUSED, ids=[name for name, _ in REFUSED])
def test_what_browsers_cannot_play_is_refused_saying_why(
    video_sample: Samples, name: str, said: str
) -> None:
    with pytest.raises(VideoRefused) as refused:
        probe(video_sample(name), BYTES, HOURS_3)
    assert said in str(refused.value)
    assert "\n" not in str(refused.value)


def test_a_file_over_the_byte_limit_is_refused_before_ffprobe_reads_it(
    video_sample: Samples, monkeypatch: pytest.MonkeyPatch
) -> None:
    def never(path: Path) -> dict[str, Any]:
        raise AssertionError("ffprobe ran")

    monkeypatch.setattr(probing, "ffprobe", never)
    lecture = video_sample("lecture.mp4")
    with pytest.raises(VideoRefused, match=r"more than the 0 MB taken \(TAGWALL_VIDEO_MAX_BYTES\)"):
        probe(lecture, 1_000, HOURS_3)


@pytest.mark.parametrize(
    "content,said",
    [
        (b"", "is empty"),
        (b"Minutes of the meeting\n" * 50, "is not a video"),
        (None, "not a video"),
    ],
)
def test_what_is_no_video_at_all_is_refused(tmp_path: Path, video_sample: Samples,
                                             content: bytes | None, said: str) -> None:  # fmt: skip
    path = tmp_path / "file.mp4"
    # None: an MP4 cut off in its first tenth (its index never came)
    data = video_sample("lecture.mp4").read_bytes()
    path.write_bytes(content if content is not None else data[: len(data) // 10])
    with pytest.raises(VideoRefused, match=said):
        probe(path, BYTES, HOURS_3)


def test_without_ffprobe_it_says_what_to_install(
    video_sample: Samples, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(probing.shutil, "which", lambda name: None)
    with pytest.raises(NoFfprobe, match="apt-get install ffmpeg"):
        probe(video_sample("lecture.mp4"), BYTES, HOURS_3)


def test_a_file_that_holds_ffprobe_up_is_refused_after_the_timeout(
    video_sample: Samples, monkeypatch: pytest.MonkeyPatch
) -> None:
    def hangs(*args: object, **kwargs: object) -> None:
        raise subprocess.TimeoutExpired("ffprobe", probing.PROBE_TIMEOUT_S)

    monkeypatch.setattr(probing.subprocess, "run", hangs)
    with pytest.raises(VideoRefused, match="could not be read in 30 s"):
        probe(video_sample("lecture.mp4"), BYTES, HOURS_3)


def _found(**video: Any) -> dict[str, Any]:
    """ffprobe's answer for an MP4 of one H.264 stream, ``video`` changing that stream."""
    stream = {
        "codec_type": "video",
        "codec_name": "h264",
        "pix_fmt": "yuv420p",
        "width": 1080,
        "height": 1920,
        "avg_frame_rate": "30000/1001",
        **video,
    }
    return {
        "format": {"format_name": "mov,mp4,m4a,3gp,3g2,mj2", "duration": "12.5",
                   "tags": {"major_brand": "isom"}},
        "streams": [stream],
    }  # fmt: skip


def test_a_phone_video_turned_upright_is_as_shown_and_rates_are_read_as_given() -> None:
    turned = _found(side_data_list=[{"rotation": -90}], width=1920, height=1080)
    found = judge(turned, 1000, BYTES, HOURS_3)
    assert (found.width, found.height, found.fps, found.duration_s) == (1080, 1920, 29.97, 12.5)
    no_average = _found(avg_frame_rate="0/0", r_frame_rate="25/1")
    assert judge(no_average, 1000, BYTES, HOURS_3).fps == 25.0


@pytest.mark.parametrize(
    "found,said",
    [
        (_found(avg_frame_rate="0/0", r_frame_rate="0/0"), "declares no frame rate"),
        (_found(width=0), "is 0 x 1920 px"),
        (_found(width=16384), "1 to 8192 px a side"),
        ({**_found(), "format": {"format_name": "mov,mp4,m4a,3gp,3g2,mj2",
                                  "tags": {"major_brand": "qt  "}}},
         "is a QuickTime movie, not MP4"),
        ({**_found(), "format": {"format_name": "mov,mp4,m4a,3gp,3g2,mj2"}},
         "declares no duration"),
    ],
)  # fmt: skip
def test_what_the_header_declares_amiss_is_refused(found: dict[str, Any], said: str) -> None:
    with pytest.raises(VideoRefused, match=said):
        judge(found, 1000, BYTES, HOURS_3)
