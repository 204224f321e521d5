"""The ``tagwall`` command line (documented in docs/cli.md)."""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import click
from pydantic import ValidationError
from pydantic_settings import SettingsError
from sqlalchemy.exc import SQLAlchemyError

from wall_client.config import WallConfigError, load_wall, load_walls
from wall_client.kiosk import KioskError, KioskSupervisor, find_browser, format_plan, plan
from wall_client.layout import CodePurpose, Wall
from webapp.database.connection import Database, database_problem
from webapp.people.tokens import Tokens, load_tokens
from webapp.settings import Settings, lan_address
from webapp.urls import dashboard_url, overview_url, tile_path, tile_url

if TYPE_CHECKING:
    import httpx

EXIT_USAGE = 2


def load_settings(**overrides: Any) -> Settings:
    """Settings from the environment, with command-line overrides; exit 2 when invalid."""
    given = {key: value for key, value in overrides.items() if value is not None}
    try:
        return Settings(**given)
    except ValidationError as error:
        for problem in error.errors():
            field = ".".join(str(part) for part in problem["loc"]) or "settings"
            click.echo(f"error: {_setting_name(field)}: {problem['msg']}", err=True)
    except SettingsError as error:  # a value that is not even JSON, before validation
        field = str(error).removeprefix('error parsing value for field "').split('"')[0]
        reason = error.__cause__ or error
        click.echo(f"error: {_setting_name(field)}: not valid JSON ({reason})", err=True)
    sys.exit(EXIT_USAGE)


def _setting_name(field: str) -> str:
    """``info_class_max`` as the operator wrote it: ``TAGWALL_INFO_CLASS_MAX``."""
    head, _, rest = field.partition(".")
    known = head in Settings.model_fields
    return f"TAGWALL_{head.upper()}{'.' + rest if rest else ''}" if known else field


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def load_configured_walls(settings: Settings) -> dict[str, Wall]:
    """The configured walls; exit 2 when a config is invalid or there is none at all."""
    try:
        walls = load_walls(settings.wall_configs)
    except WallConfigError as error:
        click.echo(str(error), err=True)
        sys.exit(EXIT_USAGE)
    if not walls:
        where = ", ".join(str(path) for path in settings.wall_configs) or "(nothing)"
        fail(
            f"no wall configs found in {where}; point TAGWALL_WALL_CONFIGS at wall .toml "
            "files or folders (see docs/wall-config.md)"
        )
    return walls


def pick_wall(walls: dict[str, Wall], wall_id: str | None, settings: Settings) -> Wall:
    """The wall named by ``--wall``, else ``TAGWALL_DEFAULT_WALL``; exit 2 naming which
    one is unknown."""
    chosen = wall_id or settings.default_wall
    if chosen not in walls:
        known = ", ".join(sorted(walls)) or "none"
        source = "" if wall_id else "TAGWALL_DEFAULT_WALL: "
        fail(f"{source}no wall {chosen!r} (configured: {known})")
    return walls[chosen]


def open_database(settings: Settings, *, migrate: bool = True) -> Database:
    """The database, migrated first unless told not to; exit 2 with one line saying
    what is wrong when it cannot be reached or used."""
    from webapp.database.migrate import upgrade

    url = settings.resolved_database_url
    try:
        if migrate:
            upgrade(url)
        return Database(url)
    except SQLAlchemyError as error:
        fail(database_problem(error, url))


def current_tokens(settings: Settings) -> Tokens:
    """The operator and tile tokens as the server checks them (rotations included)."""
    database = open_database(settings, migrate=False)
    try:
        return load_tokens(database, settings.resolved_secret_key)
    except SQLAlchemyError as error:
        fail(database_problem(error, settings.resolved_database_url))
    finally:
        database.dispose()


@click.group()
def main() -> None:
    """tagwall: one interactive screen from a wall of monitors."""
    from webapp.logs import redact_root_handlers

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    redact_root_handlers()
    logging.getLogger("alembic.runtime.plugins").setLevel(logging.WARNING)  # startup noise


@main.command()
@click.option("--host", help="Interface to listen on (TAGWALL_HOST).")
@click.option("--port", type=int, help="Port to listen on (TAGWALL_PORT).")
def serve(host: str | None, port: int | None) -> None:
    """Upgrade the database, print the wall's URLs and serve."""
    import uvicorn

    from webapp.app import create_app
    from webapp.logs import uvicorn_log_config

    settings = load_settings(host=host, port=port)
    walls = load_configured_walls(settings)
    pick_wall(walls, None, settings)
    open_database(settings).dispose()
    print_urls(settings, walls, current_tokens(settings), reveal=sys.stdout.isatty())
    app = create_app(settings)
    uvicorn.run(
        app,
        host=settings.host,
        port=settings.port,
        ws_max_size=settings.max_frame_bytes,
        log_level="info",
        log_config=uvicorn_log_config(),
        # Client addresses come from webapp.people.addresses, from TAGWALL_TRUSTED_PROXIES only:
        # uvicorn's own proxy headers would believe X-Forwarded-For from 127.0.0.1.
        proxy_headers=False,
    )


def print_urls(
    settings: Settings, walls: dict[str, Wall], tokens: Tokens, *, reveal: bool = True
) -> None:
    """The dashboard, overview and tile URLs; with ``reveal`` off, their tokens masked
    (a server's output usually ends up in a log)."""
    from webapp.logs import redact

    def say(line: str) -> None:
        click.echo(line if reveal else redact(line))

    for line in reach(settings):
        say(line)
    say(f"  dashboard: {dashboard_url(settings, tokens)}")
    say("    (the operator's admin sign-in: keep it private, open it on this machine)")
    for wall in walls.values():
        if wall.id != settings.default_wall and len(walls) > 1:
            continue
        say(f"  overview:  {overview_url(settings, wall.id)}")
        for display in wall.displays:
            say(f"  tile {display.id}: {tile_url(settings, tokens, wall.id, display.id)}")
    others = sorted(set(walls) - {settings.default_wall})
    if others and settings.default_wall in walls:
        say(f"  other walls: {', '.join(others)} (tagwall tiles --wall NAME)")
    if not reveal:
        say("  (tokens are kept out of logs: `tagwall urls` prints the full URLs)")


def reach(settings: Settings) -> list[str]:
    """Where the server listens and whether the phones that scan its codes get there:
    the first thing `serve` says, so a first scan that cannot work is explained."""
    codes = settings.resolved_public_base_url
    if settings.listens_everywhere:
        where = f"listening on every network interface, port {settings.port}"
    elif settings.listens_locally_only:
        where = f"listening on this machine only ({settings.host}:{settings.port})"
    else:
        where = f"listening on {settings.host}:{settings.port} only"
    lines = [f"tagwall on {settings.server_url}, {where}"]
    if settings.public_base_url:
        lines.append(
            f"  phones: codes send them to {codes} (TAGWALL_PUBLIC_BASE_URL); "
            "it must lead phones to this server"
        )
    elif settings.listens_locally_only:
        lines += [
            f"  phones: cannot reach it; codes send them to {codes}, which a phone takes "
            "for itself",
            "  to let phones in: TAGWALL_HOST=0.0.0.0 make run (on a network you trust)",
        ]
    elif settings.listens_everywhere and lan_address() == "127.0.0.1":
        lines += [
            f"  phones: cannot reach it: this machine has no network address; codes send "
            f"them to {codes}",
            "  to let phones in: join the network the phones use and start again",
        ]
    else:
        lines.append(
            f"  phones on this network: codes send them to {codes} "
            f"(a firewall here must let port {settings.port} in)"
        )
        if settings.listens_everywhere:
            lines.append("  to keep it on this machine only: TAGWALL_HOST=127.0.0.1 make run")
    return lines


@main.command()
def urls() -> None:
    """Print the dashboard, overview and tile URLs of the configured walls."""
    settings = load_settings()
    walls = load_configured_walls(settings)
    pick_wall(walls, None, settings)
    print_urls(settings, walls, current_tokens(settings))


@main.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
def tiles(wall_id: str | None) -> None:
    """Print one tile URL per line, token included (for kiosk browsers)."""
    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    tokens = current_tokens(settings)
    for display in wall.displays:
        click.echo(tile_url(settings, tokens, wall.id, display.id))


@main.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
@click.option("--node", required=True, help="Render node whose displays to drive.")
@click.option("--browser", default=None, help="Browser executable (default: chromium on PATH).")
@click.option(
    "--profiles",
    type=click.Path(path_type=Path),
    default=None,
    help="Folder for per-display browser profiles (default: VAR_DIR/kiosk).",
)
@click.option(
    "--token",
    default=None,
    help="The wall's tile token (default: read from the database; give it on render "
    "nodes without database access after `tagwall tokens rotate tiles`).",
)
@click.option("--dry-run", is_flag=True, help="Print the commands instead of running them.")
def kiosk(
    wall_id: str | None,
    node: str,
    browser: str | None,
    profiles: Path | None,
    token: str | None,
    dry_run: bool,
) -> None:
    """Launch one kiosk browser per display of a render node; restart any that crash."""
    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    displays = wall.nodes().get(node)
    if not displays:
        known = ", ".join(wall.nodes())
        click.echo(f"error: wall {wall.id!r} has no node {node!r} (nodes: {known})", err=True)
        sys.exit(EXIT_USAGE)
    try:
        executable = browser or find_browser()
    except KioskError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_USAGE)
    tile_token = token or current_tokens(settings).tile(wall.id)
    tile_urls = {d.id: settings.server_url + tile_path(tile_token, wall.id, d.id) for d in displays}
    commands = plan(
        displays,
        tile_urls,
        browser=executable,
        profile_root=profiles or settings.var_dir / "kiosk" / wall.id,
    )
    if dry_run:
        for line in format_plan(commands):
            click.echo(line)
        return
    KioskSupervisor(commands).run()


@main.group()
def config() -> None:
    """Wall configuration files."""


@config.command("check")
@click.argument("files", nargs=-1, required=True, type=click.Path(path_type=Path))
def config_check(files: tuple[Path, ...]) -> None:
    """Validate wall config FILES; exit status 2 when any is invalid."""
    failed = False
    for path in files:
        try:
            wall = load_wall(path)
        except WallConfigError as error:
            click.echo(str(error), err=True)
            failed = True
            continue
        click.echo(
            f"{path}: ok: wall {wall.id!r}, {len(wall.displays)} displays, "
            f"{wall.width:.0f} x {wall.height:.0f} mm, bezel mode {wall.bezel_mode}"
        )
    if failed:
        sys.exit(EXIT_USAGE)


@main.group()
def codes() -> None:
    """QR codes: how big they must be."""


@codes.command("size")
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
@click.option(
    "--distance",
    type=click.FloatRange(min=0.1, max=100),
    default=None,
    help="Scanning distance in metres (default: the wall's distance for --purpose).",
)
@click.option(
    "--purpose",
    type=click.Choice(["walk-up", "seat"]),
    default="seat",
    show_default=True,
    help="Codes marking the scene (walk-up) or serving the room (seat).",
)
@click.option(
    "--qr-version",
    type=click.IntRange(1, 40),
    default=2,
    show_default=True,
    help="QR version to size (2 holds a typical LAN URL code).",
)
def codes_size(
    wall_id: str | None, distance: float | None, purpose: CodePurpose, qr_version: int
) -> None:
    """Print the code size on each display for a purpose's design distance."""
    from tag_service.sizing import Camera, code_size, min_module_mm, symbol_modules

    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    distance = distance or wall.design_distance_m(purpose)
    camera = Camera()
    module_mm = min_module_mm(distance, camera)
    modules = symbol_modules(17 + 4 * qr_version)
    click.echo(
        f"wall {wall.id}, {purpose} codes, scanning distance {distance:g} m:"
        f" modules of at least {module_mm:.2f} mm"
        f" ({camera.field_of_view_deg:g} deg field of view, {camera.frame_px} px frames,"
        f" {camera.px_per_module:g} camera px per module)"
    )
    click.echo(f"QR version {qr_version}: {modules} modules across, 4-module quiet zones included")
    click.echo(
        f"{'display':<10}{'mm/px':>8}{'px/module':>11}{'module mm':>11}{'code px':>9}{'code mm':>9}"
    )
    for display in wall.displays:
        size = code_size(display, modules, module_mm)
        fits = "" if size.side_px <= min(display.mounted_resolution) else "  (does not fit)"
        click.echo(
            f"{display.id:<10}{display.mm_per_px:>8.3f}{size.px_per_module:>11}"
            f"{size.module_mm:>11.2f}{size.side_px:>9}{size.side_mm:>9.1f}{fits}"
        )


@main.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
@click.option("--server", default=None, help="Server URL (default: the configured server).")
@click.option("--browser", default=None, help="Chromium executable (default: chromium on PATH).")
def check(wall_id: str | None, server: str | None, browser: str | None) -> None:
    """Screenshot every tile of a running wall and decode its codes; exit 1 on any failure."""
    import httpx

    try:
        from webapp.check import check_wall, fetch_layout
    except ImportError as missing:  # Playwright is the `check` extra
        click.echo(f"error: tagwall check needs pip install 'tagwall[check]' ({missing})", err=True)
        sys.exit(EXIT_USAGE)

    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    server_url = (server or settings.local_url).rstrip("/")
    tokens = current_tokens(settings)
    try:
        executable = browser or find_browser()
        version, layout = fetch_layout(server_url, wall.id, tokens.operator)
    except (KioskError, httpx.HTTPError) as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_USAGE)
    token = tokens.tile(wall.id)
    urls = {d.id: server_url + tile_path(token, wall.id, d.id) for d in wall.displays}
    report = check_wall(wall, urls, version, layout, executable)
    for line in report.lines():
        click.echo(line)
    if not report.ok:
        sys.exit(1)


@main.group()
def db() -> None:
    """The database."""


@db.command("upgrade")
@click.option("--revision", default="head", show_default=True)
def db_upgrade(revision: str) -> None:
    """Apply migrations up to REVISION (serve does this by itself)."""
    from webapp.database.migrate import upgrade

    settings = load_settings()
    try:
        upgrade(settings.resolved_database_url, revision)
    except SQLAlchemyError as error:
        fail(database_problem(error, settings.resolved_database_url))
    click.echo(f"database at {revision}")


@main.group()
def user() -> None:
    """Instructor and admin accounts."""


def _account_action(action: Callable[[Database], str]) -> None:
    """Run ``action`` on the database; its message on success, exit 1 with the reason
    when the account request cannot be carried out."""
    from webapp.people.accounts import AccountError

    database = open_database(load_settings())
    try:
        click.echo(action(database))
    except AccountError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(1)
    finally:
        database.dispose()


@user.command("add")
@click.argument("name")
@click.option(
    "--role",
    type=click.Choice(["instructor", "admin"]),
    default="instructor",
    show_default=True,
    help="What the account may do.",
)
@click.password_option(help="The password (asked for when not given).")
def user_add(name: str, role: str, password: str) -> None:
    """Add an account (the password is asked for twice, never echoed)."""
    from webapp.people.accounts import add_account

    _account_action(
        lambda db: f"added {add_account(db, name, role, password, actor='cli').username} ({role})"
    )


@user.command("list")
def user_list() -> None:
    """List the accounts: username, role, created."""
    from webapp.people.accounts import list_accounts

    def listing(db: Database) -> str:
        rows = [f"{a.username}\t{a.role}\t{a.created_at:%Y-%m-%d}" for a in list_accounts(db)]
        return "\n".join(rows) or "no accounts"

    _account_action(listing)


@user.command("remove")
@click.argument("name")
def user_remove(name: str) -> None:
    """Remove an account; phones it signed in or paired become students."""
    from webapp.people.accounts import remove_account

    def remove(db: Database) -> str:
        remove_account(db, name, actor="cli")
        return f"removed {name}"

    _account_action(remove)


@user.command("passwd")
@click.argument("name")
@click.password_option(help="The new password (asked for when not given).")
def user_passwd(name: str, password: str) -> None:
    """Set a new password; phones signed in with the old one are signed out."""
    from webapp.people.accounts import set_password

    def change(db: Database) -> str:
        set_password(db, name, password, actor="cli")
        return f"password of {name} changed"

    _account_action(change)


@main.group()
def tokens() -> None:
    """The operator's and the tiles' tokens."""


@tokens.command("rotate")
@click.argument("which", type=click.Choice(["operator", "tiles"]))
@click.option("--wall", "wall_id", default=None, help="Only this wall's tile token.")
def tokens_rotate(which: str, wall_id: str | None) -> None:
    """Replace the operator token or the tile tokens; the old ones stop working within
    seconds, on every server process, and the new URLs are printed."""
    from webapp.people.person import revoke
    from webapp.people.tokens import OPERATOR, rotate, tile_purpose

    settings = load_settings()
    walls = load_configured_walls(settings)
    chosen = [pick_wall(walls, wall_id, settings)] if wall_id else list(walls.values())
    database = open_database(settings)
    try:
        if which == "operator":
            rotate(database, [OPERATOR], actor="cli")
            signed_out = revoke(database, ["operator"], actor="cli")
        else:
            rotate(database, [tile_purpose(wall.id) for wall in chosen], actor="cli")
        new = load_tokens(database, settings.resolved_secret_key)
    except SQLAlchemyError as error:
        fail(database_problem(error, settings.resolved_database_url))
    finally:
        database.dispose()
    if which == "operator":
        click.echo(f"new operator sign-in link: {dashboard_url(settings, new)}")
        click.echo(f"browsers signed in with the old link signed out: {signed_out}")
        return
    for wall in chosen:
        click.echo(f"wall {wall.id}: new tile URLs (open tiles are closed within seconds)")
        for display in wall.displays:
            click.echo(f"  {tile_url(settings, new, wall.id, display.id)}")


@main.group()
def volume() -> None:
    """Volumes shown across the wall (brick stores)."""


def _spacing(_: click.Context, __: click.Parameter, value: str | None) -> Any:
    if value is None:
        return None
    try:
        numbers = tuple(float(part) for part in value.split(","))
    except ValueError:
        numbers = ()
    if len(numbers) != 3 or min(numbers) <= 0:
        raise click.BadParameter("give three positive numbers like 1,1,1.5")
    return numbers


@volume.command("build")
@click.argument("source", type=click.Path(path_type=Path))
@click.argument("out", required=False, type=click.Path(path_type=Path))
@click.option("--name", help="The volume's name (default: OUT's name, else the file's).")
@click.option("--brick", type=int, default=32, show_default=True, help="Brick side, voxels.")
@click.option("--depth", type=int, help="Octree depth instead (2**depth bricks across).")
@click.option("--empty-below", type=float, help="Drop bricks whose values are all below this.")
@click.option("--spacing", callback=_spacing, help="Voxel size in mm as X,Y,Z (.npy input).")
def volume_build(
    source: Path,
    out: Path | None,
    name: str | None,
    brick: int,
    depth: int | None,
    empty_below: float | None,
    spacing: tuple[float, float, float] | None,
) -> None:
    """Build SOURCE (.nii, .nii.gz or .npy) into the brick store OUT
    (default: TAGWALL_VOLUME_DIR/NAME), a slab at a time."""
    from webapp.volume.build import VolumeBuildError, build_store, open_source

    stem = source.name.removesuffix(".gz").removesuffix(".nii").removesuffix(".npy")
    name = name or (out.name if out else stem)
    out = out or load_settings().resolved_volume_dir / name
    try:
        meta = build_store(
            open_source(source, spacing),
            out,
            name=name,
            brick=brick,
            depth=depth,
            empty_below=empty_below,
            progress=lambda done, total: click.echo(f"\rslab {done}/{total}", nl=False),
        )
    except VolumeBuildError as error:
        click.echo(f"error: {error}", err=True)
        sys.exit(EXIT_USAGE)
    size = sum(p.stat().st_size for p in out.iterdir())
    click.echo(
        f"\n{out}: {meta.name}, {meta.shape[0]} x {meta.shape[1]} x {meta.shape[2]} voxels, "
        f"bricks of {meta.brick}: {meta.stored_bricks} stored, {meta.empty_bricks} empty; "
        f"{size / 1e6:.1f} MB"
    )


@volume.command("list")
def volume_list() -> None:
    """The volumes in TAGWALL_VOLUME_DIR."""
    from webapp.volume.catalog import VolumeCatalog
    from webapp.volume.store import VolumeStoreError

    settings = load_settings()
    catalog = VolumeCatalog(settings.resolved_volume_dir, cache_voxels=0)
    names = catalog.names()
    if not names:
        click.echo(f"no volumes in {catalog.directory}; build one with `tagwall volume build`")
    for name in names:
        try:
            meta = catalog.get(name).meta
        except VolumeStoreError as error:
            click.echo(f"{name}: unreadable: {error}")
            continue
        x, y, z = meta.shape
        click.echo(
            f"{name}: {x} x {y} x {z} voxels of {meta.spacing[0]:g} mm, from {meta.source}; "
            f"{meta.stored_bricks} bricks of {meta.brick}, {meta.levels} levels"
        )


@main.group()
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
    type=click.Path(path_type=Path, dir_okay=False),
    help="CSV of values by key (default: the shapes' own columns).",
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
    table: Path | None,
    settings_file: Path | None,
    name: str | None,
    strict: bool,
) -> None:
    """Import a census data set and make it the one the census map shows."""
    from webapp.apps.census_map.importer import CensusImportError, import_files

    settings = load_settings()
    database = open_database(settings)
    try:
        report = import_files(
            database,
            shapes=shapes,
            key=key,
            table=table,
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
    import httpx

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
    from webapp.apps.census_map.store import list_datasets

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


@main.group()
def content() -> None:
    """Teaching content the apps read (the brain atlas's regions and texts)."""


@content.command("check")
@click.option(
    "--dir",
    "directory",
    type=click.Path(path_type=Path, file_okay=False),
    default=None,
    help="The brain atlas content folder (default: content/brain_atlas).",
)
def content_check(directory: Path | None) -> None:
    """Check the brain atlas's regions, tutor texts, references and view presets (every
    region must show in one of them); exit 2 on problems."""
    from webapp.apps.brain_atlas.content import ATLAS_DIR, ContentError, load_content
    from webapp.apps.brain_atlas.pins import AtlasVolumes, PinCache
    from webapp.apps.brain_atlas.views import load_views, showing

    folder = directory or ATLAS_DIR
    try:
        loaded = load_content(folder)
        presets = load_views(folder / "views.yaml")
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
