"""Resolving scans quickly: what codes are, briefly cached; scans recorded in batches.

When a room of phones scans the wall at once, each scan should cost a dictionary
lookup, not a database transaction. A code's tag and its wall's active tag set are
cached for ``ttl_s`` seconds (and dropped at once when any process changes tags or
sets: it says so on the bus); the scans are queued and written by one INSERT every
``interval_s``. The rules themselves (live, in the active set) stay in :mod:`webapp.tags.registry`.

Trade-offs, documented in ``docs/codes.md``: a change made by *another* server process
reaches this one's cache as soon as its word does, and within ``ttl_s`` should the word
be lost (a bus outage); scans queued when the process is killed
hard (not stopped) are lost, at most ``interval_s`` worth.
"""

from __future__ import annotations

import asyncio
import hashlib
import logging
import threading
import time
from collections import OrderedDict
from contextlib import AbstractAsyncContextManager
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import insert, select
from sqlalchemy.exc import SQLAlchemyError

from webapp.core.threads import run_blocking
from webapp.database.connection import Database, as_utc
from webapp.database.models import ScanRecord, TagRecord, WallStateRecord
from webapp.engine.bus.base import BusUnavailable, EventBus, Subscription
from webapp.engine.bus.forgetting import Forgetting
from webapp.engine.protocol import ScanSeen
from webapp.tags.registry import is_live, shown_in

log = logging.getLogger(__name__)

MAX_ADDRESS = 64
MAX_USER_AGENT = 400


@dataclass(frozen=True)
class Resolution:
    """What a scanned code turned out to be: its tag, and why it does not work if not."""

    tag: TagRecord | None
    problem: str | None = None


@dataclass(frozen=True)
class _Facts:
    tag: TagRecord | None  # detached, read-only
    active_set: str | None
    loaded_at: float


CODES = "codes"
"""The bus channel on which a process says it changed codes (`webapp.engine.bus.forgetting`)."""


class CodeDirectory:
    """Codes as the scan path needs them, from the database, cached for ``ttl_s``.

    :meth:`forget` drops the cache here and, through ``bus``, in every process that
    :meth:`follow` s it; ``ttl_s`` bounds how stale a look-up is when that word is lost.
    """

    def __init__(
        self,
        db: Database,
        ttl_s: float = 2.0,
        max_codes: int = 10_000,
        bus: EventBus | None = None,
    ) -> None:
        self.db = db
        self.ttl_s = ttl_s
        self.max_codes = max_codes
        self._facts: OrderedDict[str, _Facts] = OrderedDict()
        self._generation = 0  # bumped by a drop: loads begun before it are not kept
        self._forgetting = Forgetting(bus, CODES, self._drop)

    async def resolve(self, code: str) -> Resolution:
        """The tag behind ``code`` and, if it does not work now, why."""
        facts = self._facts.get(code)
        if facts is None or time.monotonic() - facts.loaded_at > self.ttl_s:
            generation = self._generation
            facts = await run_blocking(self._load, code)
            if generation == self._generation:
                self._facts[code] = facts
                self._facts.move_to_end(code)
                if len(self._facts) > self.max_codes:
                    self._facts.popitem(last=False)
        return _judge(facts)

    def forget(self) -> None:
        """Drop everything cached: tags or tag sets changed in this process. The other
        processes are told (callable from a worker thread too), while :meth:`follow` runs."""
        self._forgetting.forget()

    async def follow(self, opened: asyncio.Event | None = None) -> None:
        """Hear the other processes' :meth:`forget` until cancelled (the app's lifespan)."""
        await self._forgetting.follow(opened)

    def _drop(self) -> None:
        self._generation += 1
        self._facts.clear()

    def _load(self, code: str) -> _Facts:
        with self.db.session() as session:
            tag = session.get(TagRecord, code)
            state = session.get(WallStateRecord, tag.wall_id) if tag is not None else None
            active_set = state.state.get("tag_set") if state is not None else None
            return _Facts(tag, active_set, time.monotonic())


def _judge(facts: _Facts) -> Resolution:
    tag = facts.tag
    if tag is None:
        return Resolution(None)
    if not is_live(tag):
        return Resolution(tag, "This code has been switched off or has expired.")
    if not shown_in(tag, facts.active_set):
        return Resolution(
            tag, f"This code belongs to the {tag.tag_set!r} codes, which are not on the wall now."
        )
    return Resolution(tag)


class ScanLog:
    """Scans queued in memory and written in batches, one INSERT per batch."""

    def __init__(self, db: Database, interval_s: float = 0.1, max_pending: int = 100_000) -> None:
        self.db = db
        self.interval_s = interval_s
        self.max_pending = max_pending
        self._pending: list[dict[str, Any]] = []
        self._lock = threading.Lock()  # guards the queue
        self._writing = threading.Lock()  # one batch written at a time

    def record(self, tag: TagRecord, visitor_id: str, client_address: str, user_agent: str) -> None:
        row = {
            "code": tag.code,
            "wall_id": tag.wall_id,
            "visitor_id": visitor_id,
            "client_address": client_address[:MAX_ADDRESS],
            "user_agent": user_agent[:MAX_USER_AGENT],
            "scanned_at": datetime.now(UTC),
        }
        with self._lock:
            if len(self._pending) < self.max_pending:
                self._pending.append(row)

    def flush(self) -> int:
        """Write what is queued (thread-safe); returns how many scans were written.

        When it returns, every scan recorded before the call is in the database: a
        batch another thread took from the queue is waited for, not skipped."""
        with self._writing:
            with self._lock:
                rows, self._pending = self._pending, []
            if not rows:
                return 0
            try:  # Core's executemany: the ORM's bulk insert cost twice as much per row
                with self.db.engine.begin() as connection:
                    connection.execute(insert(ScanRecord), rows)
            except Exception:
                with self._lock:  # keep them for the next try, oldest first
                    self._pending = (rows + self._pending)[: self.max_pending]
                raise
            return len(rows)

    async def run(self) -> None:
        """Flush every ``interval_s`` until cancelled (the app's lifespan owns this task).

        While the database is down the scans wait in memory; that is said once, and
        once more when they are written again."""
        failing = False
        while True:
            await asyncio.sleep(self.interval_s)
            try:
                await run_blocking(self.flush)
            except SQLAlchemyError as error:
                if not failing:
                    log.warning("could not record scans (%s); will retry", type(error).__name__)
                failing = True
                continue
            except Exception:
                log.exception("could not record scans; will retry")
                continue
            if failing:
                log.warning("recording scans again")
                failing = False


def scans_of(db: Database, code: str) -> list[ScanRecord]:
    """The recorded scans of ``code``, oldest first (queued ones once flushed)."""
    with db.session() as session:
        return list(
            session.scalars(
                select(ScanRecord).where(ScanRecord.code == code).order_by(ScanRecord.id)
            )
        )


def scan_notice(tag: TagRecord, visitor_id: str, at_ms: int) -> ScanSeen:
    """What dashboards are told of a scan: the code, and the visitor by a short
    pseudonym, stable per visitor."""
    return ScanSeen(
        wall=tag.wall_id,
        code=tag.code,
        label=tag.label,
        app=tag.app,
        visitor=hashlib.sha256(visitor_id.encode()).hexdigest()[:6],
        at=at_ms,
    )


def recent_scans(db: Database, wall_id: str, limit: int) -> list[ScanSeen]:
    """The wall's last ``limit`` recorded scans, oldest first, as dashboards were told
    of them: a dashboard opened (or reloaded) starts its feed from these."""
    with db.session() as session:
        rows = session.execute(
            select(ScanRecord.visitor_id, ScanRecord.scanned_at, TagRecord)
            .join(TagRecord, TagRecord.code == ScanRecord.code)
            .where(ScanRecord.wall_id == wall_id)
            .order_by(ScanRecord.id.desc())
            .limit(limit)
        ).all()
        return [
            scan_notice(tag, visitor_id, int(as_utc(at).timestamp() * 1000))
            for visitor_id, at, tag in reversed(rows)
        ]


SCANS = "scans"
"""The bus channel of a wall's scans, for dashboards (see :mod:`webapp.engine.bus`)."""


class ScanFeed:
    """Scans as they happen, for the dashboards of the wall, on any process: each scan
    goes on the wall's ``scans`` channel of the bus.

    Each dashboard has a bounded subscription; one that does not keep up is dropped
    (its page says so) rather than slowing the scan path down.
    """

    def __init__(self, bus: EventBus) -> None:
        self.bus = bus

    async def publish(self, tag: TagRecord, visitor_id: str) -> None:
        """Tell the wall's dashboards; a bus that does not answer loses the notice only
        (the scan is recorded)."""
        notice = scan_notice(tag, visitor_id, time.time_ns() // 1_000_000)
        try:
            await self.bus.publish(tag.wall_id, notice.model_dump_json(), SCANS)
        except BusUnavailable as error:
            log.warning("wall %s: a scan not shown on dashboards: %s", tag.wall_id, error)

    def subscribe(self, wall_id: str) -> AbstractAsyncContextManager[Subscription]:
        """The wall's scans as ``ScanSeen`` frames (JSON text), from any process."""
        return self.bus.subscribe(wall_id, SCANS)
