"""What every ``tagwall`` command shares, the core's and the apps': settings from the
environment, one-line errors that exit 2, the walls, the database, the bus and the
tokens."""

from __future__ import annotations

import asyncio
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NoReturn

import click
from pydantic import ValidationError
from pydantic_settings import SettingsError
from sqlalchemy.exc import SQLAlchemyError

from wall_client.config import WallConfigError, load_walls
from wall_client.layout import Wall
from webapp.core.settings import Settings, setting_name, setting_problems
from webapp.database.connection import Database, database_problem
from webapp.database.migrate import upgrade
from webapp.database.redis import redis_problem
from webapp.people.tokens import Tokens, load_tokens

EXIT_USAGE = 2


def load_settings(**overrides: Any) -> Settings:
    """Settings from the environment, with command-line overrides; exit 2 when invalid."""
    given = {key: value for key, value in overrides.items() if value is not None}
    try:
        return Settings(**given)
    except ValidationError as error:
        for line in setting_problems(error, Settings):
            click.echo(f"error: {line}", err=True)
    except SettingsError as error:  # a value that is not even JSON, before validation
        field = str(error).removeprefix('error parsing value for field "').split('"')[0]
        reason = error.__cause__ or error
        click.echo(f"error: {setting_name(Settings, field)}: not valid JSON ({reason})", err=True)
    sys.exit(EXIT_USAGE)


def fail(message: str, code: int = EXIT_USAGE) -> NoReturn:
    click.echo(f"error: {message}", err=True)
    sys.exit(code)


def load_configured_walls(settings: Settings) -> dict[str, Wall]:
    """The configured walls; exit 2 when a config is invalid or there is none at all."""
    try:
        walls = load_walls(settings.resolved_wall_configs)
    except WallConfigError as error:
        click.echo(str(error), err=True)
        sys.exit(EXIT_USAGE)
    if not walls:
        where = ", ".join(str(path) for path in settings.resolved_wall_configs) or "(nothing)"
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


def open_database(
    settings: Settings, apps: Mapping[str, Path] | None = None, *, migrate: bool = True
) -> Database:
    """The database, migrated first unless told not to (the core's tables, and the own
    tables of ``apps``: {name: its revisions' folder}); exit 2 with one line saying what
    is wrong when it cannot be reached or used."""
    url = settings.resolved_database_url
    try:
        if migrate:
            upgrade(url, apps=apps)
        return Database(url)
    except SQLAlchemyError as error:
        fail(database_problem(error, url))


def check_bus(settings: Settings) -> None:
    """With ``TAGWALL_BUS=redis``, exit 2 with one line when Redis does not answer."""
    if settings.bus == "redis" and (problem := asyncio.run(redis_problem(settings.redis_url))):
        fail(problem)


def require_installation(settings: Settings) -> None:
    """Exit 2 with one line when ``TAGWALL_VAR_DIR`` holds no installation to read: no
    secret key there (none configured) or no SQLite database there (none configured),
    rather than make a new one up and print links that no server answers. Creates
    nothing."""
    var_dir = settings.var_dir
    lacking = []
    if not settings.secret_key and not (var_dir / "secret_key").is_file():
        lacking.append("no secret_key")
    if not settings.database_url and not (var_dir / "tagwall.db").is_file():
        lacking.append("no tagwall.db")
    if lacking:
        fail(
            f"there is no tagwall installation in {var_dir.resolve()} ({' and '.join(lacking)}"
            f" there): point TAGWALL_VAR_DIR at the installation's folder, or start one"
            f" there with `tagwall serve`"
        )


def current_tokens(settings: Settings) -> Tokens:
    """The operator and tile tokens as the server checks them (rotations included)."""
    database = open_database(settings, migrate=False)
    try:
        return load_tokens(database, settings.resolved_secret_key)
    except SQLAlchemyError as error:
        fail(database_problem(error, settings.resolved_database_url))
    finally:
        database.dispose()
