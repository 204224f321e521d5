"""Database migrations (Alembic) run from code: `tagwall db upgrade`, serve, tests."""

from __future__ import annotations

from alembic import command
from alembic.config import Config

from webapp.core.settings import PROJECT_ROOT


def alembic_config(url: str) -> Config:
    config = Config(str(PROJECT_ROOT / "alembic.ini"))
    config.set_main_option("script_location", str(PROJECT_ROOT / "migrations"))
    config.set_main_option("sqlalchemy.url", url.replace("%", "%%"))
    return config


def upgrade(url: str, revision: str = "head") -> None:
    """Bring the database at ``url`` to ``revision`` (creating SQLite files as needed)."""
    command.upgrade(alembic_config(url), revision)
