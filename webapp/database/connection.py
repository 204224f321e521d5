"""Database engine and sessions: SQLite embedded by default, PostgreSQL at scale."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import Annotated, Any, ParamSpec, TypeVar

from annotated_types import Interval
from sqlalchemy import Connection, Engine, MetaData, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import (
    ArgumentError,
    DBAPIError,
    InterfaceError,
    OperationalError,
    SQLAlchemyError,
)
from sqlalchemy.exc import TimeoutError as PoolTimeout
from sqlalchemy.orm import DeclarativeBase, Session, sessionmaker

from webapp.core.threads import run_blocking

P = ParamSpec("P")
T = TypeVar("T")

# Stable constraint names keep Alembic autogenerate and SQLite batch mode honest.
NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


ROW_ID_MAX = 2**31 - 1
"""The largest id an INTEGER column holds on PostgreSQL (SQLite holds more): the API
takes only ids both databases can look up, and answers anything larger like any
unknown id, instead of failing in the driver."""

RowId = Annotated[int, Interval(ge=1, le=ROW_ID_MAX)]
"""A row id (publication, layout, census data set, quiz round) as the API accepts it."""


def is_row_id(value: int) -> bool:
    """Whether ``value`` can be a row's id (:data:`RowId`) on both databases: an id from
    a page's address that cannot is no row, answered as one that is not there, where
    the driver would fail on it (SQLite takes 64 bits, PostgreSQL's INTEGER 32)."""
    return 1 <= value <= ROW_ID_MAX


class Base(DeclarativeBase):
    """Declarative base of every tagwall table."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)


SQLITE_POOL_SIZE = 48
"""Connections a SQLite engine keeps open: as many as threads can hold sessions at once
(the thread pool's 40 and the walls' own 8). An overflow connection is closed when it
is returned, so a smaller pool opened a file, and ran the pragmas, for every busy
request; an open SQLite connection costs a file handle and its page cache."""


def make_engine(url: str) -> Engine:
    """An engine for ``url``; for SQLite, create the parent folder and enable WAL.

    A pooled connection to a server is pinged before use, so one the server dropped
    (a restart) is replaced instead of failing a request; a SQLite file cannot drop
    its connections, and a ping would cost every session a statement."""
    parsed = make_url(url)
    kwargs: dict[str, Any] = {"pool_pre_ping": parsed.get_backend_name() != "sqlite"}
    if parsed.get_backend_name() == "sqlite":
        kwargs["connect_args"] = {"check_same_thread": False, "timeout": 30}
        kwargs |= {"pool_size": SQLITE_POOL_SIZE, "max_overflow": SQLITE_POOL_SIZE}
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
    engine = create_engine(url, **kwargs)
    if parsed.get_backend_name() == "sqlite":
        event.listen(engine, "connect", _sqlite_pragmas)
    return engine


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    """WAL lets tiles read while a change is written; foreign keys are off by default."""
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.close()


class Database:
    """An engine and its session factory; one per app, held in ``app.state``."""

    def __init__(self, url: str) -> None:
        self.url = url
        self.engine = make_engine(url)
        self.sessions = sessionmaker(self.engine, expire_on_commit=False)
        self.embedded = self.engine.dialect.name == "sqlite"
        self._held = threading.local()  # each thread's open reading connection

    async def read(self, function: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
        """Run ``function``, a phone's short read, for a coroutine: in a worker thread
        for a database server (its round trips must not hold the event loop), but
        right here for SQLite. A read of the embedded file (a tenth of a millisecond,
        never waiting for a lock in WAL mode) costs less than the hand-off to a
        thread and back, which phones paid twice a page. Every :meth:`reading` of
        ``function`` shares one connection: one check-out (and, for a server, one
        ping) for the page's reads."""
        shared = partial(self._reading_through, function, *args, **kwargs)
        return shared() if self.embedded else await run_blocking(shared)

    def _reading_through(self, function: Callable[P, T], *args: P.args, **kwargs: P.kwargs) -> T:
        with self.reading():
            return function(*args, **kwargs)

    @contextmanager
    def session(self) -> Iterator[Session]:
        """A session committed on success and rolled back on error."""
        with self.sessions() as session, session.begin():
            yield session

    @contextmanager
    def reading(self) -> Iterator[Connection]:
        """A connection for the reads on a phone's path, which are most of what its
        pages cost. A Core statement built once (a module constant, its values as
        ``bindparam``) runs on it in about a third of the time the same read takes
        through an ORM session: no unit of work, identity map or instances, and no
        statement to build and match to its compiled form. Nothing is written.

        Within another reading of the same thread, the same connection: the calls are
        synchronous, so nothing else runs on it meanwhile."""
        held: Connection | None = getattr(self._held, "connection", None)
        if held is not None:
            yield held
            return
        with self.engine.connect() as connection:
            self._held.connection = connection
            try:
                yield connection
            finally:
                self._held.connection = None

    def ping(self) -> bool:
        """True when the database answers a trivial query."""
        try:
            with self.engine.connect() as connection:
                connection.execute(text("SELECT 1"))
        except Exception:
            return False
        return True

    def dispose(self) -> None:
        self.engine.dispose()


def is_outage(error: SQLAlchemyError) -> bool:
    """True when ``error`` means the database cannot be reached or used right now (down,
    restarting, out of connections, a lost connection), not that a query was wrong.

    Out of connections includes this process's own pool: a session that waited the
    pool's timeout (30 s) for a connection while every one was checked out (a server
    loaded beyond what it answers in time) raises ``sqlalchemy.exc.TimeoutError``
    before its transaction began, so it changed nothing; trying again is right."""
    if isinstance(error, DBAPIError) and error.connection_invalidated:
        return True
    return isinstance(error, OperationalError | InterfaceError | PoolTimeout)


def database_problem(error: Exception, url: str) -> str:
    """One line saying what is wrong with the database at ``url`` (password hidden), for
    an operator who has to fix it."""
    try:
        shown = make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        shown = repr(url)
    if isinstance(error, ArgumentError):
        return (
            f"TAGWALL_DATABASE_URL {shown} is not a database URL tagwall can use "
            "(like sqlite:///var/tagwall.db or postgresql+psycopg://user@host:5432/tagwall)"
        )
    reason = str(getattr(error, "orig", None) or error).strip().splitlines()
    first = reason[0] if reason else type(error).__name__
    if "file is not a database" in first or "malformed" in first:
        return (
            f"the SQLite database {make_url(url).database} is damaged or not a database "
            f"({first}); restore it from a backup, or move it away to start afresh"
        )
    return f"cannot use the database at {shown}: {first}"


def as_utc(value: datetime) -> datetime:
    """``value`` as an aware UTC time: SQLite hands back naive datetimes, and naive
    input means UTC here."""
    return value.replace(tzinfo=UTC) if value.tzinfo is None else value
