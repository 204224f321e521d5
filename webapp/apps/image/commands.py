"""The image app's commands: ``tagwall image add``, ``list``, ``remove``, and a lesson's
``export``, ``import`` and ``check``."""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path
from typing import NoReturn

import click

from webapp.apps.image.lesson import LessonRefused, export, import_lesson, inspect
from webapp.apps.image.library import ImageLibrary, ImageShown, remove_image
from webapp.apps.image.store import ImageRefused, NoLibvips
from webapp.cli.console import (
    EXIT_USAGE,
    fail,
    load_configured_walls,
    load_settings,
    open_database,
)


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


@image.command("remove")
@click.argument("image_id", metavar="ID")
def image_remove(image_id: str) -> None:
    """Remove image ID with its pyramid and hotspots, all or nothing; exit 2 for no such
    image or one a wall shows (show another there first)."""
    settings = load_settings()
    walls = load_configured_walls(settings)
    database = open_database(settings)
    try:
        removed = remove_image(ImageLibrary().store(settings), database, walls.values(), image_id)
    except KeyError:
        fail(f"There is no image {image_id}.")
    except ImageShown as error:
        fail(str(error))
    finally:
        database.dispose()
    click.echo(f"removed {removed.id}: {removed.title!r}")


@image.command("export")
@click.argument("image_id", metavar="ID")
@click.argument("file", type=click.Path(path_type=Path, dir_okay=False))
def image_export(image_id: str, file: Path) -> None:
    """Write the lesson of image ID (the image, its hotspots, texts and questions) to
    FILE (a .tagwall-lesson ZIP) for another installation; exit 2 for no such image."""
    try:
        lesson = export(ImageLibrary().store(load_settings()), image_id, file)
    except KeyError:
        fail(f"There is no image {image_id}.")
    except NoLibvips as error:
        fail(str(error))
    click.echo(f"exported {image_id}: {lesson.title!r}, {len(lesson.hotspots)} hotspots, to {file}")


def _refused(problems: list[str]) -> NoReturn:
    """Every problem of a lesson file on a line of its own, a count, exit 2."""
    for problem in problems:
        click.echo(problem, err=True)
    click.echo(f"{len(problems)} problem(s) found", err=True)
    sys.exit(EXIT_USAGE)


@image.command("import")
@click.argument("file", type=click.Path(path_type=Path, exists=True, dir_okay=False))
def image_import(file: Path) -> None:
    """Store the lesson in FILE as a new image with its hotspots, all or nothing; every
    problem one line and exit 2 when it is refused (nothing is kept)."""
    try:
        added, spots = import_lesson(ImageLibrary().store(load_settings()), file)
    except LessonRefused as error:
        _refused(error.problems)
    except NoLibvips as error:
        fail(str(error))
    click.echo(
        f"imported {added.id}: {added.title!r}, {added.width} x {added.height} px, "
        f"{len(spots)} hotspots"
    )


@image.command("check")
@click.argument("file", type=click.Path(path_type=Path, exists=True, dir_okay=False))
def image_check(file: Path) -> None:
    """Check the lesson file FILE as an import would, storing nothing: one line per
    problem and exit 2, or a summary."""
    store = ImageLibrary().store(load_settings())
    try:
        with tempfile.TemporaryDirectory(prefix="tagwall-lesson-") as scratch:
            lesson, _ = inspect(store, file, Path(scratch))
    except LessonRefused as error:
        _refused(error.problems)
    except NoLibvips as error:
        fail(str(error))
    click.echo(
        f"ok: {lesson.title!r}, {lesson.image.width} x {lesson.image.height} px, "
        f"{len(lesson.hotspots)} hotspots, {sum(1 for s in lesson.hotspots if s.question)} "
        "questions"
    )
