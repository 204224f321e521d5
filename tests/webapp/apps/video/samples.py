"""Videos the video app's tests make with ffmpeg: tiny (a second at 64 x 36 px), each a
kind of file an instructor may bring, kept once per test process."""

from __future__ import annotations

import subprocess
from pathlib import Path

ONE_SECOND = ["-f", "lavfi", "-i", "testsrc=s=64x36:r=30:d=1"]
TONE = ["-f", "lavfi", "-i", "sine=f=440:d=1"]
SAMPLES: dict[str, list[str]] = {
    # what browsers play
    "lecture.mp4": [*ONE_SECOND, *TONE, "-c:v", "libx264", "-pix_fmt", "yuv420p", "-c:a", "aac"],
    "silent.mp4": [*ONE_SECOND, "-c:v", "libx264", "-pix_fmt", "yuv420p"],
    "lecture.webm": [*ONE_SECOND, *TONE, "-c:v", "libvpx-vp9", "-pix_fmt", "yuv420p", "-c:a",
                     "libopus"],
    # what they do not
    "hevc.mp4": [*ONE_SECOND, "-c:v", "libx265", "-pix_fmt", "yuv420p", "-x265-params",
                 "log-level=none"],
    "ten-bit.mp4": [*ONE_SECOND, "-c:v", "libx264", "-pix_fmt", "yuv420p10le"],
    "old.mp4": [*ONE_SECOND, "-c:v", "mpeg4"],
    "lecture.avi": [*ONE_SECOND, "-c:v", "mpeg4"],
    "h264.mkv": [*ONE_SECOND, "-c:v", "libx264", "-pix_fmt", "yuv420p"],
    "ac3.mp4": [*ONE_SECOND, *TONE, "-c:v", "libx264", "-pix_fmt", "yuv420p", "-c:a", "ac3"],
    "talk.m4a": [*TONE, "-c:a", "aac"],
    # a whole day's recording, one frame in ten minutes: four hours in 2 kB
    "four-hours.mp4": ["-f", "lavfi", "-i", "color=s=16x16:r=1/600:d=14400", "-c:v", "libx264",
                       "-pix_fmt", "yuv420p"],
}  # fmt: skip


def make(name: str, folder: Path) -> Path:
    """Write the sample ``name`` into ``folder``."""
    target = folder / name
    subprocess.run(
        ["ffmpeg", "-v", "error", "-y", *SAMPLES[name], str(target)],
        check=True,
        capture_output=True,
        timeout=120,
    )
    return target
