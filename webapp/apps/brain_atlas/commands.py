"""The brain atlas's command: ``tagwall content check``."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from webapp.apps.brain_atlas.content import ContentError, atlas_folder, load_content
from webapp.apps.brain_atlas.pins import AtlasVolumes, PinCache
from webapp.apps.brain_atlas.views import VIEWS_NAME, load_views, showing
from webapp.cli.console import EXIT_USAGE, load_settings


@click.group()
def content() -> None:
    """Teaching content the apps read (the brain atlas's regions and texts)."""


@content.command("check")
@click.option(
    "--dir",
    "directory",
    type=click.Path(path_type=Path, file_okay=False),
    default=None,
    help="The brain atlas content folder (default: brain_atlas/ of TAGWALL_CONTENT_DIR, "
    "the folder the server reads).",
)
def content_check(directory: Path | None) -> None:
    """Check the brain atlas's regions, tutor texts, references and view presets (every
    region must show in one of them), one line per problem; exit 2 on problems."""
    folder = directory or atlas_folder(load_settings())
    click.echo(f"checking {folder}")
    try:
        loaded = load_content(folder)
        presets = load_views(folder / VIEWS_NAME)
        shown = showing(presets, loaded.regions, AtlasVolumes.load(folder), PinCache())
    except ContentError as error:
        for problem in error.problems:
            click.echo(problem, err=True)
        click.echo(f"{len(error.problems)} problem(s) found", err=True)
        sys.exit(EXIT_USAGE)
    unseen = [region_id for region_id, ids in shown.items() if not ids]
    for region_id in unseen:
        click.echo(f"views.yaml: no view shows the pin of {region_id}", err=True)
    if unseen:
        click.echo(f"{len(unseen)} problem(s) found", err=True)
        sys.exit(EXIT_USAGE)
    click.echo(
        f"ok: {len(loaded.in_set('full'))} quiz regions, {len(loaded.in_set('k5'))} K-5 "
        f"regions, {len(loaded.tutors)} tutor files, {len(loaded.references)} references, "
        f"{len(presets)} views showing every pin"
    )
