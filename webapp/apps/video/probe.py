"""Whether a file is a video every tile's browser plays, asked of ffprobe.

ffprobe (Debian's ``ffmpeg`` package) reads the file's container and streams in a
process of its own, so a parser of untrusted files never runs inside the server, and
one that hangs on a hostile file is killed after :data:`PROBE_TIMEOUT_S`. What it says
is judged here, one rule for the dashboard's upload and ``tagwall video add``: an MP4
with H.264 video (and AAC sound, or none), or a WebM with VP8, VP9 or AV1 video (and
Vorbis or Opus sound, or none), 8-bit 4:2:0 pixels (10-bit for VP9 and AV1), within
the duration and byte limits. Anything else is refused in one line saying what the
file is and what browsers play.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

PROBE_TIMEOUT_S = 30.0
MAX_SIDE = 8192
"""The largest width or height taken (8K UHD is 7680 x 4320; browsers decode little more)."""
MP4_BRANDS_NOT = frozenset({"qt"})
"""Major brands of the MP4 family's container that are not MP4 (QuickTime's ``qt  ``)."""
MP4_VIDEO = {"h264": "H.264"}
MP4_AUDIO = {"aac": "AAC"}
WEBM_VIDEO = {"vp8": "VP8", "vp9": "VP9", "av1": "AV1"}
WEBM_AUDIO = {"vorbis": "Vorbis", "opus": "Opus"}
PIXELS = {
    "h264": frozenset({"yuv420p", "yuvj420p"}),
    "vp8": frozenset({"yuv420p"}),
    "vp9": frozenset({"yuv420p", "yuv420p10le"}),
    "av1": frozenset({"yuv420p", "yuv420p10le"}),
}
"""The pixel formats browsers decode per codec: 4:2:0, 8-bit (10-bit for VP9 and AV1;
Chromium plays no 10-bit H.264, High 10, nor any 4:2:2 or 4:4:4)."""
CODEC_NAMES = {
    "hevc": "H.265",
    "mpeg4": "MPEG-4 Part 2",
    "mpeg2video": "MPEG-2",
    "prores": "ProRes",
    "mp3": "MP3",
    "ac3": "AC-3",
    "eac3": "E-AC-3",
    "pcm_s16le": "PCM",
    **MP4_VIDEO,
    **MP4_AUDIO,
    **WEBM_VIDEO,
    **WEBM_AUDIO,
}


class VideoRefused(ValueError):
    """A file that is not stored; the message says why in one line."""


class NoFfprobe(RuntimeError):
    """ffprobe is not installed: videos cannot be added (those stored still play)."""


@dataclass(frozen=True)
class Probed:
    """What the wall and the dashboard need to know of a video a browser plays."""

    container: str  # "mp4" or "webm"
    video_codec: str  # "h264", "vp8", "vp9", "av1"
    audio_codec: str | None  # "aac", "vorbis", "opus"; None: silent
    width: int  # as shown (a phone's portrait video turned upright)
    height: int
    fps: float
    duration_s: float


def _name(codec: str) -> str:
    return CODEC_NAMES.get(codec, codec)


def ffprobe(path: Path) -> dict[str, Any]:
    """ffprobe's JSON of ``path``'s container and streams; VideoRefused when it cannot
    read it (not a media file), NoFfprobe when it is not installed."""
    program = shutil.which("ffprobe")
    if program is None:
        raise NoFfprobe("ffprobe is not installed: apt-get install ffmpeg")
    try:
        done = subprocess.run(
            [program, "-v", "error", "-show_format", "-show_streams", "-of", "json", str(path)],
            capture_output=True,
            timeout=PROBE_TIMEOUT_S,
            check=False,
        )
    except subprocess.TimeoutExpired:
        raise VideoRefused(f"could not be read in {PROBE_TIMEOUT_S:g} s") from None
    if done.returncode != 0:
        raise VideoRefused("is not a video (ffprobe cannot read it)")
    found: dict[str, Any] = json.loads(done.stdout or b"{}")
    return found


def _rate(stream: dict[str, Any]) -> float:
    """The frame rate: the average one, else the container's base rate; 0 if neither."""
    for key in ("avg_frame_rate", "r_frame_rate"):
        try:
            rate = Fraction(str(stream.get(key, "0/0")))
        except (ValueError, ZeroDivisionError):
            continue
        if rate > 0:
            return float(rate)
    return 0.0


def _rotated(stream: dict[str, Any]) -> bool:
    """Whether the video is shown turned a quarter (a phone's portrait video)."""
    for side in stream.get("side_data_list", []):
        rotation = side.get("rotation")
        if rotation is not None and abs(int(float(rotation))) % 180 == 90:
            return True
    return False


def judge(found: dict[str, Any], size: int, max_bytes: int, max_duration_s: float) -> Probed:
    """What ffprobe ``found`` in a file of ``size`` bytes, if browsers play it within
    the limits; VideoRefused saying why not (the caller puts the file's name first)."""
    _within_bytes(size, max_bytes)
    form = found.get("format", {})
    names = set(str(form.get("format_name", "")).split(","))
    streams = found.get("streams", [])
    pictures = [s for s in streams if s.get("codec_type") == "video"]
    videos = [s for s in pictures if not s.get("disposition", {}).get("attached_pic")]
    audios = [s for s in streams if s.get("codec_type") == "audio"]
    if not videos:
        heard = f" ({_name(audios[0]['codec_name'])} sound only)" if audios else ""
        raise VideoRefused(f"has no video stream{heard}")
    video, audio = videos[0], audios[0] if audios else None
    quicktime = str(form.get("tags", {}).get("major_brand", "")).strip() in MP4_BRANDS_NOT
    if "mp4" in names and not quicktime:
        container, video_codecs, audio_codecs = "mp4", MP4_VIDEO, MP4_AUDIO
    elif "webm" in names:
        container, video_codecs, audio_codecs = "webm", WEBM_VIDEO, WEBM_AUDIO
    else:
        kind = "a QuickTime movie" if quicktime else form.get("format_long_name") or "unknown"
        raise VideoRefused(f"is {kind}, not MP4 or WebM: browsers play MP4 (H.264) and WebM")
    label = "MP4" if container == "mp4" else "WebM"
    codec = str(video.get("codec_name", ""))
    if codec not in video_codecs:
        taken = " or ".join(video_codecs.values())
        raise VideoRefused(
            f"is {label} with {_name(codec)} video, which browsers do not all play: "
            f"{label} takes {taken}"
        )
    pixels = str(video.get("pix_fmt", ""))
    if pixels not in PIXELS[codec]:
        raise VideoRefused(
            f"has {_name(codec)} video in {pixels or 'unknown'} pixels, which browsers do "
            "not decode: encode it as yuv420p (8-bit 4:2:0)"
        )
    if audio is not None and str(audio.get("codec_name", "")) not in audio_codecs:
        taken = " or ".join(audio_codecs.values())
        raise VideoRefused(
            f"has {_name(str(audio.get('codec_name', '')))} sound, which browsers do not "
            f"play in {label}: {label} takes {taken} (or no sound)"
        )
    width, height = int(video.get("width") or 0), int(video.get("height") or 0)
    if not (0 < width <= MAX_SIDE and 0 < height <= MAX_SIDE):
        raise VideoRefused(f"is {width} x {height} px: 1 to {MAX_SIDE} px a side are taken")
    fps = _rate(video)
    if fps <= 0:
        raise VideoRefused("declares no frame rate")
    try:
        duration = float(form.get("duration") or video.get("duration") or 0)
    except ValueError:
        duration = 0.0
    if duration <= 0:
        raise VideoRefused("declares no duration (a stream cut short, or a live recording)")
    if duration > max_duration_s:
        raise VideoRefused(
            f"lasts {_hours(duration)}, longer than the {_hours(max_duration_s)} taken "
            "(TAGWALL_VIDEO_MAX_DURATION_S)"
        )
    if _rotated(video):
        width, height = height, width
    return Probed(
        container=container,
        video_codec=codec,
        audio_codec=str(audio["codec_name"]) if audio is not None else None,
        width=width,
        height=height,
        fps=round(fps, 3),
        duration_s=round(duration, 3),
    )


def _within_bytes(size: int, max_bytes: int) -> None:
    if size > max_bytes:
        raise VideoRefused(
            f"is {size / 1e6:,.1f} MB, more than the {max_bytes / 1e6:,.0f} MB taken "
            "(TAGWALL_VIDEO_MAX_BYTES)"
        )


def _hours(seconds: float) -> str:
    """A duration as people say it: 4 h 0 min, 12 min 5 s, 9.5 s."""
    if seconds >= 3600:
        return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60)} min"
    if seconds >= 60:
        return f"{int(seconds // 60)} min {int(seconds % 60)} s"
    return f"{seconds:g} s"


def probe(path: Path, max_bytes: int, max_duration_s: float) -> Probed:
    """Judge the file at ``path`` (:func:`judge`)."""
    size = path.stat().st_size
    if size == 0:
        raise VideoRefused("is empty")
    _within_bytes(size, max_bytes)  # before ffprobe reads a byte of it
    return judge(ffprobe(path), size, max_bytes, max_duration_s)
