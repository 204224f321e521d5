"""The census map's commands: ``tagwall census import`` and ``tagwall census list``."""

from __future__ import annotations

import sys
from pathlib import Path

import click
import httpx

from webapp.apps.census_map.importer import CensusImportError, import_files
from webapp.apps.census_map.store import list_datasets
from webapp.console import current_tokens, load_settings, open_database
from webapp.settings import Settings


@click.group()
def census() -> None:
    """Census data sets for the census map."""


@census.command("import")
@click.option(
    "--shapes",
    required=True,
    type=click.Path(path_type=Path, dir_okay=False),
    help="Tract outlines: .shp, a .zip holding one shapefile, or .geojson.",
)
@click.option("--key", required=True, help="The column joining shapes and table (e.g. GEOID).")
@click.option(
    "--table",
    "tables",
    multiple=True,
    type=click.Path(path_type=Path, dir_okay=False),
    help="Values by key: a CSV, or a data.census.gov table (its -Data.csv with the "
    "-Column-Metadata.csv beside it, or the downloaded .zip); repeat for more tables "
    "(default: the shapes' own columns).",
)
@click.option(
    "--settings",
    "settings_file",
    type=click.Path(path_type=Path, dir_okay=False),
    help="Settings TOML (default: the .toml beside the shapes, else generated).",
)
@click.option("--name", help="The data set's name (default: the shapes' file name).")
@click.option("--strict", is_flag=True, help="Refuse any unmatched key, repair or skip.")
def census_import(
    shapes: Path,
    key: str,
    tables: tuple[Path, ...],
    settings_file: Path | None,
    name: str | None,
    strict: bool,
) -> None:
    """Import a census data set and make it the one the census map shows."""
    settings = load_settings()
    database = open_database(settings)
    try:
        report = import_files(
            database,
            shapes=shapes,
            key=key,
            tables=tables,
            settings=settings_file,
            name=name,
            strict=strict,
        )
    except CensusImportError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(1)
    finally:
        database.dispose()
    for line in report.lines():
        click.echo(line)
    click.echo(_switch_census_map(settings, report.dataset_id))


def _switch_census_map(settings: Settings, dataset_id: int) -> str:
    """Ask a running server to show the new data set now; what happened, as a line.
    The import already made it current, so a server that is down shows it at start."""
    url = f"{settings.local_url}/api/census/current"
    token = current_tokens(settings).operator
    try:
        response = httpx.post(
            url,
            json={"dataset": dataset_id},
            headers={"Authorization": f"Bearer {token}"},
            timeout=5,
        )
    except (httpx.ConnectError, httpx.TimeoutException):
        return (
            f"the server ({settings.local_url}) is not reachable; "
            f"the map switches to data set {dataset_id} when it next starts"
        )
    except httpx.HTTPError as error:
        return (
            f"could not tell the server ({settings.local_url}) to switch the map: {error}; "
            f"it shows data set {dataset_id} when it next starts"
        )
    if response.is_error:
        return (
            f"the server did not switch the map: {response.status_code} {_error_detail(response)}"
        )
    return f"the map now shows data set {dataset_id}"


def _error_detail(response: httpx.Response) -> str:
    """FastAPI's ``detail``, else the start of the body."""
    try:
        detail = response.json().get("detail")
    except (ValueError, AttributeError):
        detail = None
    return str(detail) if detail is not None else response.text[:200]


@census.command("list")
def census_list() -> None:
    """The stored data sets, the current one marked with *."""
    database = open_database(load_settings())
    try:
        datasets = list_datasets(database)
    finally:
        database.dispose()
    if not datasets:
        click.echo("no census data sets; import one with `tagwall census import`")
    for d in datasets:
        mark = "*" if d.current else " "
        click.echo(
            f"{mark} {d.id:>4}  {d.name}  {d.title!r}  {d.tract_count} tracts  "
            f"{d.created_at:%Y-%m-%d %H:%M} UTC"
        )
