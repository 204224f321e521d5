"""The database layer on both backends the project supports."""

from __future__ import annotations

import pytest

from webapp.database.connection import Database
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
