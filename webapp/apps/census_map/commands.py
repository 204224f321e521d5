"""The census map's commands: ``tagwall census import``, ``tagwall census list`` and
``tagwall earth``."""

from __future__ import annotations

import sys
from pathlib import Path

import click
import httpx

from webapp.apps.census_map.earth import (
    DEFAULT_FOV,
    DEFAULT_MAP_REFRESH_S,
    DEFAULT_REFRESH_S,
    MAX_FOV,
    MAX_REFRESH_S,
    MIN_FOV,
    MIN_REFRESH_S,
    EarthBase,
    EarthOptions,
    base_signature,
    opener_kml,
    opener_url,
    screen_role,
)
from webapp.apps.census_map.importer import CensusImportError, import_files
from webapp.apps.census_map.store import list_datasets
from webapp.cli.console import (
    current_tokens,
    fail,
    load_configured_walls,
    load_settings,
    open_database,
    pick_wall,
)
from webapp.core.settings import Settings


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


# Connecting is quick or fails at once (no server); switching the map loads the data set
# and places codes on every wall that shows it, which a busy machine takes a while over.
SWITCH_TIMEOUT = httpx.Timeout(60.0, connect=5.0)


def _switch_census_map(settings: Settings, dataset_id: int) -> str:
    """Ask a running server to show the new data set now; what happened, as a line.
    The import already made it current, so a server that is down shows it at start."""
    url = f"{settings.local_url}/api/apps/census/current"
    token = current_tokens(settings).operator
    try:
        response = httpx.post(
            url,
            json={"dataset": dataset_id},
            headers={"Authorization": f"Bearer {token}"},
            timeout=SWITCH_TIMEOUT,
        )
    except (httpx.ConnectError, httpx.ConnectTimeout):
        return (
            f"the server ({settings.local_url}) is not reachable; "
            f"the map switches to data set {dataset_id} when it next starts"
        )
    except httpx.TimeoutException:
        # It took the request and is still at it (a busy machine loads the data set and
        # places codes on every wall showing the map): the switch may yet happen.
        return (
            f"the server ({settings.local_url}) is busy: it took the request but did not "
            f"answer within {SWITCH_TIMEOUT.read:g} s, so it may still be switching the map; "
            f"data set {dataset_id} is imported and current either way (the dashboard shows "
            f"which the map shows; a restart shows it)"
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


REFRESH = click.IntRange(MIN_REFRESH_S, MAX_REFRESH_S)


@click.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
@click.option(
    "--out",
    type=click.Path(path_type=Path, file_okay=False),
    help="Write each display's KML file into this folder instead of printing URLs.",
)
@click.option(
    "--base-url",
    help="Where Google Earth reaches the server (default: TAGWALL_PUBLIC_BASE_URL, else "
    "where the server listens).",
)
@click.option(
    "--fov",
    type=click.FloatRange(MIN_FOV, MAX_FOV),
    default=DEFAULT_FOV,
    show_default=True,
    help="Google Earth's horizontal field of view on these displays, degrees.",
)
@click.option(
    "--refresh",
    type=REFRESH,
    default=DEFAULT_REFRESH_S,
    show_default=True,
    help="Seconds between fetches of each display's view, groups, balloon and codes.",
)
@click.option(
    "--map-refresh",
    type=REFRESH,
    default=DEFAULT_MAP_REFRESH_S,
    show_default=True,
    help="Seconds between fetches of the map itself.",
)
def earth(
    wall_id: str | None,
    out: Path | None,
    base_url: str | None,
    fov: float,
    refresh: int,
    map_refresh: int,
) -> None:
    """What each display's Google Earth Pro opens to show the census map (a Google
    Earth wall); the designated screens stay browser tiles."""
    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    base = (base_url or settings.resolved_public_base_url).rstrip("/")
    if not base.startswith(("http://", "https://")):
        fail(f"--base-url must be an http:// or https:// URL, not {base!r}")
    options = EarthOptions(fov=fov, refresh=refresh, map_refresh=map_refresh)
    public = settings.resolved_public_base_url
    # Another base than the public one is signed, so the server names URLs on it.
    earth_base = EarthBase(base)
    if base != public:
        earth_base = EarthBase(base, base_signature(settings.resolved_secret_key, base))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    width = max(len(d.id) for d in wall.displays)
    click.echo(f"{'display':<{width}}  Google Earth Pro opens")
    for display in wall.displays:
        role = screen_role(wall, display.id)
        if role is not None:
            what = f"(the {role} screen: a browser tile, see `tagwall tiles`)"
        elif out is not None:
            path = out / f"{display.id}.kml"
            path.write_text(opener_kml(earth_base, wall, display.id, options))
            what = str(path)
        else:
            what = opener_url(earth_base, wall.id, display.id, options)
        click.echo(f"{display.id:<{width}}  {what}")
