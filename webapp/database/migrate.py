"""Database migrations (Alembic) run from code: `tagwall db upgrade`, serve, tests.

The core's revisions are in ``migrations/versions``. An app may keep tables of its own
with revisions in its package (``WallApp.migrations``): each app's are a history of
their own, recorded in a version table of its own (``alembic_version_<app>``), so the
core's upgrades never depend on which apps are installed, and an app uninstalled and
installed again goes on from where its tables stand.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from alembic import command
from alembic.config import Config

from webapp.core.settings import PROJECT_ROOT

CORE_VERSION_TABLE = "alembic_version"


def alembic_config(url: str, app: str | None = None, versions: Path | None = None) -> Config:
    """The core's migrations at ``url``, or those of ``app`` in its ``versions`` folder."""
    config = Config(str(PROJECT_ROOT / "alembic.ini"))
    config.set_main_option("script_location", str(PROJECT_ROOT / "migrations"))
    config.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    if app is not None and versions is not None:
        config.set_main_option("version_locations", str(versions).replace("%", "%%"))
        config.set_main_option("version_table", version_table(app))
    return config


def version_table(app: str) -> str:
    """Where the revision of ``app``'s own tables is recorded."""
    return f"{CORE_VERSION_TABLE}_{app}"


def upgrade(url: str, revision: str = "head", apps: Mapping[str, Path] | None = None) -> None:
    """Bring the database at ``url`` to the core's ``revision`` (creating SQLite files as
    needed), then every app of ``apps`` ({name: its revisions' folder}) to its head."""
    command.upgrade(alembic_config(url), revision)
    for app, versions in sorted((apps or {}).items()):
        command.upgrade(alembic_config(url, app, versions), "head")


def downgrade(url: str, revision: str, apps: Mapping[str, Path] | None = None) -> None:
    """Take the core's tables down to ``revision``; the tables of ``apps`` stand on the
    core's, so they go down first, to before their first revision."""
    for app, versions in sorted((apps or {}).items()):
        command.downgrade(alembic_config(url, app, versions), "base")
    command.downgrade(alembic_config(url), revision)


def downgrade_app(url: str, app: str, versions: Path, revision: str) -> None:
    """Take ``app``'s own tables down to its ``revision`` (``base``: none of them)."""
    command.downgrade(alembic_config(url, app, versions), revision)
