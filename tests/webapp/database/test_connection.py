"""The database layer on both backends the project supports."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest
from sqlalchemy import create_engine, event, select
from sqlalchemy.exc import OperationalError, ProgrammingError, SQLAlchemyError
from sqlalchemy.exc import TimeoutError as PoolTimeout

from tests.conftest import migrate
from webapp.database.connection import SQLITE_POOL_SIZE, Database, is_outage, make_engine
from webapp.database.models import WallStateRecord


def test_ping_answers_when_the_database_does(database_url: str) -> None:
    migrate(database_url)
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


def test_a_pool_out_of_connections_is_an_outage(database_url: str) -> None:
    """Waiting the pool's timeout for a connection (all checked out) is the server out
    of connections: try again (503), not a wrong query (500)."""
    engine = create_engine(database_url, pool_size=1, max_overflow=0, pool_timeout=0.05)
    try:
        with engine.connect(), pytest.raises(PoolTimeout) as waited:
            engine.connect()
        assert is_outage(waited.value)
    finally:
        engine.dispose()
    wrong: SQLAlchemyError = ProgrammingError("SELECT nonsense", {}, Exception("syntax"))
    assert not is_outage(wrong)
    assert is_outage(OperationalError("SELECT 1", {}, Exception("server closed")))


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


def test_a_sqlite_engine_keeps_a_connection_for_every_thread(tmp_path: Path) -> None:
    """As many threads as may hold a session at once find an open connection: none is
    opened (its pragmas run) again and again while a room's requests keep them busy."""
    db = Database(f"sqlite:///{tmp_path / 'x.db'}")
    opened: list[object] = []
    event.listen(db.engine, "connect", lambda connection, _record: opened.append(connection))
    try:
        held = [db.engine.connect() for _ in range(SQLITE_POOL_SIZE)]
        for connection in held:
            connection.close()
        for _ in range(3):
            held = [db.engine.connect() for _ in range(SQLITE_POOL_SIZE)]
            for connection in held:
                connection.close()
        assert len(opened) == SQLITE_POOL_SIZE
    finally:
        db.dispose()


async def test_short_reads_stay_on_the_event_loop_with_sqlite_only(database_url: str) -> None:
    """SQLite's reads run where they are awaited (cheaper than a thread hop); a database
    server's go to a worker thread, whose round trips must not hold the event loop."""
    db = Database(database_url)
    try:
        where = await db.read(threading.get_ident)
        embedded = db.engine.dialect.name == "sqlite"
        assert db.embedded is embedded
        assert (where == threading.get_ident()) is embedded
    finally:
        db.dispose()


def test_a_reading_connection_sees_what_sessions_committed(database_url: str) -> None:
    migrate(database_url)
    db = Database(database_url)
    try:
        with db.session() as session:
            session.add(WallStateRecord(wall_id="demo", version=3, state={"app": "brain"}))
        with db.reading() as connection:
            row = connection.execute(select(WallStateRecord.version)).one()
        assert row.version == 3
    finally:
        db.dispose()


async def test_the_reads_of_one_page_share_a_connection(database_url: str) -> None:
    """Every reading within one ``read`` is the same connection (one check-out, one ping
    for a server); each reading of its own checks one out."""
    db = Database(database_url)

    def connections() -> set[int]:
        seen = set()
        for _ in range(3):
            with db.reading() as connection:
                seen.add(id(connection))
        return seen

    try:
        assert len(await db.read(connections)) == 1
        with db.reading() as outer, db.reading() as inner:
            assert inner is outer
        with db.reading() as first:
            pass
        with db.reading() as second:
            assert second is not first
    finally:
        db.dispose()
