"""The image app's commands: ``tagwall image add`` and ``tagwall image list``."""

from __future__ import annotations

import time
from pathlib import Path

import click

from webapp.apps.image.library import ImageLibrary
from webapp.apps.image.store import ImageRefused, NoLibvips
from webapp.cli.console import fail, load_settings


@click.group()
def image() -> None:
    """Images for the image app: tile pyramids under the var folder."""


@image.command("add")
@click.argument("file", type=click.Path(path_type=Path, exists=True, dir_okay=False))
@click.option("--title", default=None, help="What the dashboard calls it (default: the file name).")
def image_add(file: Path, title: str | None) -> None:
    """Store FILE (PNG, JPEG or TIFF) as a tile pyramid the wall can show; a running
    server lists it at once. Exit 2 when the file is refused (nothing is kept)."""
    store = ImageLibrary().store(load_settings())
    started = time.monotonic()
    try:
        added = store.add(file, title)
    except (ImageRefused, NoLibvips) as error:
        fail(str(error))
    click.echo(
        f"added {added.id}: {added.title!r}, {added.width} x {added.height} px, "
        f"{added.levels} levels, in {time.monotonic() - started:.1f} s"
    )


@image.command("list")
def image_list() -> None:
    """The stored images, newest first: id, size and title."""
    for stored in ImageLibrary().store(load_settings()).images():
        click.echo(f"{stored.id}  {stored.width} x {stored.height} px  {stored.title}")
