"""The ``tagwall`` command line (documented in docs/cli.md)."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import click
import httpx
import uvicorn
from alembic.util import CommandError
from sqlalchemy.exc import SQLAlchemyError

from tag_service.fit import fits_display, largest_distance
from tag_service.sizing import Camera, code_size, min_module_mm, symbol_modules
from wall_client.config import WallConfigError, load_wall, load_walls
from wall_client.kiosk import KioskError, KioskSupervisor, find_browser, format_plan, plan
from wall_client.layout import CodePurpose, Wall
from webapp.apps.discovery import AppLoadError, installed_apps
from webapp.apps.fitting import fit_lines, wall_fit
from webapp.apps.hooks import ContentCheck, WallApp
from webapp.apps.installed import wall_apps
from webapp.cli.campus import oidc
from webapp.cli.console import (
    EXIT_USAGE,
    check_bus,
    current_tokens,
    fail,
    load_configured_walls,
    load_settings,
    open_database,
    pick_wall,
    require_installation,
)
from webapp.core.logs import redact, redact_root_handlers, uvicorn_log_config
from webapp.core.settings import Settings, lan_address
from webapp.database.connection import Database, database_problem
from webapp.database.migrate import downgrade, downgrade_app, upgrade
from webapp.people.accounts import (
    AccountError,
    add_account,
    list_accounts,
    remove_account,
    set_password,
)
from webapp.people.person import revoke
from webapp.people.tokens import OPERATOR, Tokens, load_tokens, rotate, tile_purpose
from webapp.server.app import create_app
from webapp.volume.build import VolumeBuildError, build_store, open_source
from webapp.volume.catalog import VolumeCatalog
from webapp.volume.store import VolumeStoreError
from webapp.web.urls import dashboard_url, overview_url, tile_path, tile_url

logger = logging.getLogger(__name__)


class CommandsWithApps(click.Group):
    """The core's commands and those each app contributes (``WallApp.commands``).

    An app that cannot be loaded leaves the core's commands (and ``--help``) working:
    its problems are printed, with how to switch it off, in place of its commands."""

    def _apps_commands(self) -> dict[str, click.Command]:
        try:
            apps = installed_apps(load_settings().apps)
        except AppLoadError as error:
            for problem in error.problems:
                click.echo(f"warning: {problem}", err=True)
            click.echo(
                "warning: apps' commands are left out; TAGWALL_APPS=name,... loads only "
                "the apps named",
                err=True,
            )
            return {}
        return {
            command.name: command
            for app in apps.values()
            for command in app.commands()
            if command.name
        }

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *self._apps_commands()})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        return super().get_command(ctx, cmd_name) or self._apps_commands().get(cmd_name)


def check_apps(settings: Settings) -> None:
    """Stop with one line when an installed app cannot be loaded, or the first app a
    wall shows (``TAGWALL_FIRST_APP``) is not installed."""
    shown = wall_apps(_apps(settings))
    if settings.first_app not in shown:
        names = ", ".join(sorted(shown))
        fail(f"TAGWALL_FIRST_APP={settings.first_app!r} is not an installed app (apps: {names})")


@click.group(cls=CommandsWithApps)
def main() -> None:
    """tagwall: one interactive screen from a wall of monitors."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    redact_root_handlers()
    logging.getLogger("alembic.runtime.plugins").setLevel(logging.WARNING)  # startup noise


@main.command()
@click.option("--host", help="Interface to listen on (TAGWALL_HOST).")
@click.option("--port", type=int, help="Port to listen on (TAGWALL_PORT).")
@click.option(
    "--workers",
    type=click.IntRange(1, 256),
    help="Server processes sharing the port (TAGWALL_WORKERS); more than one needs "
    "TAGWALL_BUS=redis and PostgreSQL.",
)
def serve(host: str | None, port: int | None, workers: int | None) -> None:
    """Upgrade the database, print the wall's URLs and serve."""
    settings = load_settings(host=host, port=port, workers=workers)
    walls = load_configured_walls(settings)
    pick_wall(walls, None, settings)
    check_apps(settings)
    open_database(settings, app_migrations(_apps(settings))).dispose()
    check_bus(settings)
    for line in settings.content_fallbacks():
        click.echo(line)
    print_urls(settings, walls, current_tokens(settings), reveal=sys.stdout.isatty())
    log_fit(walls, _apps(), settings.resolved_public_base_url)
    if settings.workers > 1:
        # Each worker process builds its own app from the environment: hand it the
        # command line's settings that way.
        os.environ.update({"TAGWALL_HOST": settings.host, "TAGWALL_PORT": str(settings.port)})
    uvicorn.run(
        "webapp.server.app:create_app" if settings.workers > 1 else create_app(settings),
        factory=settings.workers > 1,
        workers=settings.workers,
        host=settings.host,
        port=settings.port,
        ws_max_size=settings.max_frame_bytes,
        log_level="info",
        log_config=uvicorn_log_config(),
        access_log=False,  # tagwall's own (webapp.web.middleware.AccessLogMiddleware)
        # Client addresses come from webapp.people.addresses, from TAGWALL_TRUSTED_PROXIES only:
        # uvicorn's own proxy headers would believe X-Forwarded-For from 127.0.0.1.
        proxy_headers=False,
    )


def log_fit(walls: dict[str, Wall], apps: dict[str, WallApp], base_url: str) -> None:
    """Say at start, per wall, which codes find no place on it (what `tagwall config
    check` says): the server places what it can, and a code left out is otherwise
    noticed only when someone looks for it."""
    for wall in walls.values():
        for line in fit_lines(wall_fit(wall, apps, base_url)):
            logger.warning("wall %s: %s", wall.id, line)


def print_urls(
    settings: Settings, walls: dict[str, Wall], tokens: Tokens, *, reveal: bool = True
) -> None:
    """The dashboard, overview and tile URLs; with ``reveal`` off, their tokens masked
    (a server's output usually ends up in a log)."""

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
    require_installation(settings)
    print_urls(settings, walls, current_tokens(settings))


@main.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
def tiles(wall_id: str | None) -> None:
    """Print one tile URL per line, token included (for kiosk browsers)."""
    settings = load_settings()
    wall = pick_wall(load_configured_walls(settings), wall_id, settings)
    require_installation(settings)
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
    """Validate wall config FILES and check their codes fit; exit status 2 when any is
    invalid, 1 when the core's codes (registration) do not fit one."""
    invalid = crowded = False
    apps: dict[str, WallApp] | None = None
    base_url = ""
    for path in files:
        try:
            wall = load_wall(path)
        except WallConfigError as error:
            click.echo(str(error), err=True)
            invalid = True
            continue
        if apps is None:  # only a valid wall needs them, and the URL its codes carry
            apps, base_url = _apps(), load_settings().resolved_public_base_url
        problems = wall_fit(wall, apps, base_url)
        fails = any(problem.required for problem in problems)
        crowded = crowded or fails
        click.echo(
            f"{path}: {'codes do not fit' if fails else 'ok'}: wall {wall.id!r}, "
            f"{len(wall.displays)} displays, {wall.width:.0f} x {wall.height:.0f} mm, "
            f"bezel mode {wall.bezel_mode}"
        )
        for line in fit_lines(problems):
            click.echo(f"{path}: {line}", err=True)
    if invalid:
        sys.exit(EXIT_USAGE)
    if crowded:
        sys.exit(1)


def _apps(settings: Settings | None = None) -> dict[str, WallApp]:
    """The apps ``TAGWALL_APPS`` loads, or one line per problem and exit 2."""
    try:
        return installed_apps((settings or load_settings()).apps)
    except AppLoadError as error:
        for problem in error.problems:
            click.echo(f"error: {problem}", err=True)
        sys.exit(EXIT_USAGE)


@main.group()
def content() -> None:
    """The content folder: wall configs and what the apps read (TAGWALL_CONTENT_DIR)."""


@content.command("check")
@click.option(
    "--dir",
    "directory",
    type=click.Path(path_type=Path, file_okay=False, exists=True),
    default=None,
    help="The content folder to check (default: TAGWALL_CONTENT_DIR, the one the server reads).",
)
def content_check(directory: Path | None) -> None:
    """Check the content folder before a term: its wall configs and every app's part,
    one line per problem; exit 2 on problems."""
    settings = load_settings(**({"content_dir": directory} if directory else {}))
    click.echo(f"checking {settings.content_dir}")
    walls = settings.content_folder("walls")
    try:
        found = load_walls([walls])
    except WallConfigError as error:
        checks = [ContentCheck(walls, "", error.errors)]
    else:
        checks = [ContentCheck(walls, f"{len(found)} walls: {', '.join(sorted(found))}", [])]
    for app in _apps(settings).values():
        if (checked := app.check_content(settings)) is not None:
            checks.append(checked)
    problems = [problem for check in checks for problem in check.problems]
    for check in checks:
        click.echo(f"{check.folder}: {check.summary or 'problems'}")
        for problem in check.problems:
            click.echo(f"  {problem}")
    if problems:
        click.echo(f"{len(problems)} problem(s) found", err=True)
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
    """Print the code size on each display for a purpose's design distance, whether it
    stands there with its caption, and whether the wall's codes fit."""

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
        fits = ""
        if not fits_display(wall, display.id, (modules,), distance, purpose):
            up_to = _up_to(wall, display.id, modules, distance, purpose)
            fits = f"  (does not fit with its caption; {up_to})"
        click.echo(
            f"{display.id:<10}{display.mm_per_px:>8.3f}{size.px_per_module:>11}"
            f"{size.module_mm:>11.2f}{size.side_px:>9}{size.side_mm:>9.1f}{fits}"
        )
    at_distance = (
        replace(wall, seat_distance_m=distance)
        if purpose == "seat"
        else replace(wall, walk_up_distance_m=distance)
    )
    for line in fit_lines(wall_fit(at_distance, _apps(), settings.resolved_public_base_url)):
        click.echo(line)


def _up_to(wall: Wall, display_id: str, modules: int, below_m: float, purpose: CodePurpose) -> str:
    """How far off a code of ``modules`` does stand on the display, captioned."""

    def fits(distance_m: float) -> bool:
        return fits_display(wall, display_id, (modules,), distance_m, purpose)

    distance = largest_distance(fits, below_m)
    return "no distance fits" if distance is None else f"fits up to {distance:g} m"


@main.command()
@click.option("--wall", "wall_id", default=None, help="Wall id (default: TAGWALL_DEFAULT_WALL).")
@click.option("--server", default=None, help="Server URL (default: the configured server).")
@click.option("--browser", default=None, help="Chromium executable (default: chromium on PATH).")
def check(wall_id: str | None, server: str | None, browser: str | None) -> None:
    """Screenshot every tile of a running wall and decode its codes; exit 1 on any failure."""
    try:
        from webapp.cli.check import check_wall, fetch_layout
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
@click.option("--revision", default="head", show_default=True, help="The core's revision.")
def db_upgrade(revision: str) -> None:
    """Apply the core's migrations up to REVISION and every app's own (serve does this
    by itself)."""
    settings = load_settings()
    migrations = app_migrations(_apps(settings))
    try:
        upgrade(settings.resolved_database_url, revision, migrations)
    except SQLAlchemyError as error:
        fail(database_problem(error, settings.resolved_database_url))
    apps = "".join(f", {name} at its head" for name in sorted(migrations))
    click.echo(f"database at {revision}{apps}")


@db.command("downgrade")
@click.argument("revision")
@click.option("--app", "app_name", help="Only this app's own tables, to its REVISION.")
def db_downgrade(revision: str, app_name: str | None) -> None:
    """Take the tables down to REVISION: the core's, with every app's own tables before
    them (they stand on the core's), or with --app one app's alone."""
    settings = load_settings()
    migrations = app_migrations(_apps(settings))
    url = settings.resolved_database_url
    if app_name is not None and app_name not in migrations:
        having = ", ".join(migrations) or "none"
        fail(f"no installed app {app_name!r} has tables of its own (apps that have: {having})")
    try:
        if app_name is not None:
            downgrade_app(url, app_name, migrations[app_name], revision)
        else:
            downgrade(url, revision, migrations)
    except SQLAlchemyError as error:
        fail(database_problem(error, url))
    except CommandError as error:
        fail(str(error))
    click.echo(f"{app_name or 'database'} at {revision}")


def app_migrations(apps: dict[str, WallApp]) -> dict[str, Path]:
    """The folders of the apps' own revisions, by app."""
    return {name: app.migrations for name, app in apps.items() if app.migrations is not None}


@main.group()
def user() -> None:
    """Instructor and admin accounts."""


def _account_action(action: Callable[[Database], str]) -> None:
    """Run ``action`` on the database; its message on success, exit 1 with the reason
    when the account request cannot be carried out."""

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

    _account_action(
        lambda db: f"added {add_account(db, name, role, password, actor='cli').username} ({role})"
    )


@user.command("list")
def user_list() -> None:
    """List the accounts: username, role, created, how it signs in (password or issuer)."""

    def listing(db: Database) -> str:
        rows = [
            f"{a.username}\t{a.role}\t{a.created_at:%Y-%m-%d}\t{a.issuer or 'password'}"
            for a in list_accounts(db)
        ]
        return "\n".join(rows) or "no accounts"

    _account_action(listing)


@user.command("remove")
@click.argument("name")
def user_remove(name: str) -> None:
    """Remove an account; phones it signed in or paired become students."""

    def remove(db: Database) -> str:
        remove_account(db, name, actor="cli")
        return f"removed {name}"

    _account_action(remove)


@user.command("passwd")
@click.argument("name")
@click.password_option(help="The new password (asked for when not given).")
def user_passwd(name: str, password: str) -> None:
    """Set a new password; phones signed in with the old one are signed out."""

    def change(db: Database) -> str:
        set_password(db, name, password, actor="cli")
        return f"password of {name} changed"

    _account_action(change)


main.add_command(oidc)


@main.group()
def tokens() -> None:
    """The operator's and the tiles' tokens."""


@tokens.command("rotate")
@click.argument("which", type=click.Choice(["operator", "tiles"]))
@click.option("--wall", "wall_id", default=None, help="Only this wall's tile token.")
def tokens_rotate(which: str, wall_id: str | None) -> None:
    """Replace the operator token or the tile tokens; the old ones stop working within
    seconds, on every server process, and the new URLs are printed."""

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
