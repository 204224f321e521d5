"""The database layer on both backends the project supports."""

from __future__ import annotations

from pathlib import Path

import pytest

from webapp.database.connection import Database, make_engine
from webapp.database.migrate import upgrade


def test_ping_answers_when_the_database_does(database_url: str) -> None:
    upgrade(database_url)
    db = Database(database_url)
    try:
        assert db.ping()
    finally:
        db.dispose()


def test_ping_is_false_when_the_database_is_gone() -> None:
    db = Database("postgresql+psycopg://nobody@127.0.0.1:1/none")
    try:
        assert not db.ping()
    finally:
        db.dispose()


@pytest.mark.postgres
def test_the_postgres_run_really_uses_postgres(database_url: str) -> None:
    """With TAGWALL_TEST_DATABASE_URL set, every test's database is PostgreSQL."""
    db = Database(database_url)
    try:
        assert db.engine.dialect.name == "postgresql"
        assert db.ping()
    finally:
        db.dispose()


def test_only_server_connections_are_pinged_before_use(tmp_path: Path) -> None:
    """A SQLite file cannot drop a connection: no ping statement per session there."""
    sqlite = make_engine(f"sqlite:///{tmp_path / 'x.db'}")
    server = make_engine("postgresql+psycopg://nobody@127.0.0.1:1/none")
    try:
        assert not sqlite.pool._pre_ping
        assert server.pool._pre_ping
    finally:
        sqlite.dispose()
        server.dispose()
