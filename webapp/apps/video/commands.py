"""The video app's commands: ``tagwall video add``, ``list``, ``remove`` and ``testcard``."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import click

from webapp.apps.video.library import VideoLibrary, VideoShown, remove_video
from webapp.apps.video.probe import NoFfprobe, VideoRefused
from webapp.apps.video.testcard import make_testcard
from webapp.cli.console import fail, load_configured_walls, load_settings, open_database


def _minutes(seconds: float) -> str:
    return f"{int(seconds // 60)}:{seconds % 60:04.1f}"


@click.group()
def video() -> None:
    """Videos for the video app: MP4 (H.264, AAC) and WebM files under the var folder."""


@video.command("add")
@click.argument("file", type=click.Path(path_type=Path, exists=True, dir_okay=False))
@click.option("--title", default=None, help="What the dashboard calls it (default: the file name).")
def video_add(file: Path, title: str | None) -> None:
    """Store FILE (an MP4 with H.264 video, or a WebM) for the wall to play; a running
    server lists it at once. Exit 2 when browsers would not play it, or it is over the
    size or duration limit (nothing is kept)."""
    store = VideoLibrary().store(load_settings())
    started = time.monotonic()
    try:
        added = store.add(file, title)
    except (VideoRefused, NoFfprobe) as error:
        fail(str(error))
    sound = added.audio_codec or "no sound"
    click.echo(
        f"added {added.id}: {added.title!r}, {added.width} x {added.height} px, "
        f"{_minutes(added.duration_s)} at {added.fps:g} fps, {added.video_codec}, {sound}, "
        f"in {time.monotonic() - started:.1f} s"
    )


@video.command("list")
def video_list() -> None:
    """The stored videos, newest first: id, size, duration and title."""
    for stored in VideoLibrary().store(load_settings()).videos():
        click.echo(
            f"{stored.id}  {stored.width} x {stored.height} px  {_minutes(stored.duration_s)}  "
            f"{stored.title}"
        )


@video.command("remove")
@click.argument("video_id", metavar="ID")
def video_remove(video_id: str) -> None:
    """Remove video ID; exit 2 for no such video or one a wall shows (show another
    there first)."""
    settings = load_settings()
    walls = load_configured_walls(settings)
    database = open_database(settings)
    try:
        removed = remove_video(VideoLibrary().store(settings), database, walls.values(), video_id)
    except KeyError:
        fail(f"There is no video {video_id}.")
    except VideoShown as error:
        fail(str(error))
    finally:
        database.dispose()
    click.echo(f"removed {removed.id}: {removed.title!r}")


@video.command("testcard")
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False))
@click.option("--seconds", default=120.0, show_default=True, help="How long it plays.")
@click.option("--fps", default=30, show_default=True, help="Frames per second.")
@click.option("--columns", default=3, show_default=True, help="Cells across: the wall's.")
@click.option("--rows", default=2, show_default=True, help="Cells down: the wall's.")
@click.option("--width", default=480, show_default=True, help="Pixels across (even).")
@click.option("--height", default=180, show_default=True, help="Pixels down (even).")
def video_testcard(
    file: Path, seconds: float, fps: int, columns: int, rows: int, width: int, height: int
) -> None:
    """Write a sync test card to FILE (MP4): every frame shows its number once per cell;
    with a cell per display and the stage's shape, a photo of the wall playing it shows
    one number on every display when it is in step (docs/video.md)."""
    try:
        make_testcard(file, seconds, fps, columns, rows, (width, height))
    except (ValueError, NoFfprobe) as error:
        fail(str(error))
    except subprocess.CalledProcessError as error:
        fail(f"ffmpeg failed: {error.stderr.decode(errors='replace').strip()}")
    click.echo(f"wrote {file}: {columns} x {rows} cells, {width} x {height} px, {seconds:g} s")
