"""The scan path: codes judged from a short-lived cache, scans written in batches."""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import AsyncIterator, Iterator
from datetime import UTC, datetime, timedelta

import pytest
from sqlalchemy import update
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from tests.conftest import migrate, tag_spec
from webapp.core.tasks import cancel_and_wait
from webapp.database.connection import Database
from webapp.database.models import TagRecord, WallStateRecord
from webapp.database.redis import connect_redis
from webapp.engine.bus.base import EventBus
from webapp.engine.bus.memory import MemoryBus
from webapp.engine.bus.redis import RedisBus
from webapp.engine.protocol import ScanSeen
from webapp.tags.registry import issue
from webapp.tags.scanning import CodeDirectory, ScanFeed, ScanLog, scans_of


def switch_off(db: Database, code: str) -> None:
    with db.session() as session:
        session.execute(update(TagRecord).where(TagRecord.code == code).values(active=False))


async def test_live_codes_resolve_and_the_rest_say_why(db: Database) -> None:
    codes = CodeDirectory(db)
    live = issue(db, "demo", tag_spec(), "test")
    off = issue(db, "demo", tag_spec(active=False), "test")
    expired = issue(
        db, "demo", tag_spec(expires_at=datetime.now(UTC) - timedelta(minutes=1)), "test"
    )
    hidden = issue(db, "demo", tag_spec(tag_set="k5"), "test")

    assert (await codes.resolve("NOSUCH1")).tag is None
    resolution = await codes.resolve(live.code)
    assert resolution.problem is None and resolution.tag is not None
    assert resolution.tag.code == live.code
    for tag in (off, expired):
        assert (await codes.resolve(tag.code)).problem == (
            "This code has been switched off or has expired."
        )
    problem = (await codes.resolve(hidden.code)).problem
    assert problem is not None and "'k5' codes, which are not on the wall now" in problem


async def test_the_cache_holds_for_its_ttl_and_forget_drops_it(db: Database) -> None:
    codes = CodeDirectory(db, ttl_s=60.0)
    tag = issue(db, "demo", tag_spec(), "test")
    assert (await codes.resolve(tag.code)).problem is None
    switch_off(db, tag.code)  # as another server process would
    assert (await codes.resolve(tag.code)).problem is None, "cached for the ttl"
    codes.forget()
    assert (await codes.resolve(tag.code)).problem is not None


async def test_a_changed_active_set_is_seen_after_the_ttl(db: Database) -> None:
    codes = CodeDirectory(db, ttl_s=0.0)
    tag = issue(db, "demo", tag_spec(tag_set="k5"), "test")
    assert (await codes.resolve(tag.code)).problem is not None
    with db.session() as session:
        session.add(WallStateRecord(wall_id="demo", version=1, state={"tag_set": "k5"}))
    assert (await codes.resolve(tag.code)).problem is None


async def test_an_expiry_takes_effect_at_its_instant_even_when_cached(db: Database) -> None:
    codes = CodeDirectory(db, ttl_s=60.0)
    soon = datetime.now(UTC) + timedelta(seconds=2)  # room for a loaded machine
    tag = issue(db, "demo", tag_spec(expires_at=soon), "test")
    assert (await codes.resolve(tag.code)).problem is None
    await asyncio.sleep((soon - datetime.now(UTC)).total_seconds() + 0.01)
    assert (await codes.resolve(tag.code)).problem is not None


async def test_the_cache_stays_bounded_forgetting_the_least_recent(db: Database) -> None:
    codes = CodeDirectory(db, ttl_s=60.0, max_codes=1)
    first = issue(db, "demo", tag_spec(), "test")
    assert (await codes.resolve(first.code)).problem is None
    switch_off(db, first.code)
    await codes.resolve("NOSUCH1")  # pushes the first code out
    assert (await codes.resolve(first.code)).problem is not None, "loaded afresh"


def test_scans_are_written_in_one_batch_with_every_field(db: Database) -> None:
    log = ScanLog(db)
    tag = issue(db, "demo", tag_spec(), "test")
    for index in range(5):
        log.record(tag, f"visitor-{index}", "10.0.0.7", "Phone/1.0 " + "x" * 500)
    assert scans_of(db, tag.code) == [], "queued, not yet written"
    assert log.flush() == 5
    assert log.flush() == 0
    scans = scans_of(db, tag.code)
    assert [s.visitor_id for s in scans] == [f"visitor-{i}" for i in range(5)]
    first = scans[0]
    assert (first.client_address, first.wall_id) == ("10.0.0.7", "demo")
    assert first.user_agent.startswith("Phone/1.0") and len(first.user_agent) == 400
    assert first.scanned_at is not None


def test_a_flush_waits_for_the_batch_another_thread_is_writing(
    db: Database, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The app's flusher may have taken the queue a moment ago: a flush (a test, the
    shutdown) returns only once those scans are written too."""
    log = ScanLog(db)
    tag = issue(db, "demo", tag_spec(), "test")
    log.record(tag, "visitor-1", "10.0.0.7", "Phone/1.0")
    writing, release = threading.Event(), threading.Event()
    real_session = db.session

    @contextlib.contextmanager
    def slow_session() -> Iterator[Session]:
        writing.set()
        release.wait(5)
        with real_session() as session:
            yield session

    monkeypatch.setattr(db, "session", slow_session)
    background = threading.Thread(target=log.flush)
    background.start()
    writing.wait(5)
    monkeypatch.setattr(db, "session", real_session)
    threading.Timer(0.2, release.set).start()
    log.flush()  # nothing left in the queue, but the batch in flight is waited for
    assert [s.visitor_id for s in scans_of(db, tag.code)] == ["visitor-1"]
    background.join(5)


def test_a_failed_write_keeps_the_scans_for_the_next_flush(database_url: str) -> None:
    db = Database(database_url)  # no tables yet: the write fails
    log = ScanLog(db)
    tag = TagRecord(code="ABCDEFG", wall_id="demo")
    log.record(tag, "visitor", "10.0.0.7", "ua")
    with pytest.raises(DBAPIError):
        log.flush()
    migrate(database_url)
    with db.session() as session:
        session.add(TagRecord(code="ABCDEFG", wall_id="demo", app="quiz", action="ask"))
    assert log.flush() == 1
    assert len(scans_of(db, "ABCDEFG")) == 1
    db.dispose()


def test_the_queue_is_bounded(db: Database) -> None:
    log = ScanLog(db, max_pending=3)
    tag = issue(db, "demo", tag_spec(), "test")
    for index in range(10):
        log.record(tag, f"v{index}", "a", "ua")
    assert log.flush() == 3


# --- what the processes of one installation tell each other through the bus -----------


@pytest.fixture(params=["memory", "redis"])
async def two_buses(request: pytest.FixtureRequest) -> AsyncIterator[tuple[EventBus, EventBus]]:
    """Two processes' buses on one Redis (their own clients), or one process's bus twice."""
    if request.param == "memory":
        bus = MemoryBus(64)
        yield bus, bus
        return
    url, prefix = request.getfixturevalue("redis_server"), request.getfixturevalue("redis_prefix")
    buses = [RedisBus(connect_redis(url), prefix, queue_size=64, max_len=100) for _ in range(2)]
    yield buses[0], buses[1]
    for redis_bus in buses:
        await redis_bus.close()
        await redis_bus.redis.aclose()


async def test_a_scan_taken_by_one_process_shows_on_a_dashboard_of_another(
    db: Database, two_buses: tuple[EventBus, EventBus]
) -> None:
    taking, showing = ScanFeed(two_buses[0]), ScanFeed(two_buses[1])
    tag = issue(db, "demo", tag_spec(), "test")
    other = issue(db, "other", tag_spec(), "test")
    async with showing.subscribe("demo") as dashboard:
        await taking.publish(other, "visitor-2")  # another wall's: not shown here
        await taking.publish(tag, "visitor-1")
        async with asyncio.timeout(30):
            notice = ScanSeen.model_validate_json(await dashboard.next())
    assert (notice.wall, notice.code, notice.label) == ("demo", tag.code, tag.label)
    assert notice.visitor != "visitor-1" and len(notice.visitor) == 6


async def test_codes_forgotten_in_one_process_are_forgotten_in_another(
    db: Database, two_buses: tuple[EventBus, EventBus]
) -> None:
    """The cache holds a minute here: only the word from the other process drops it."""
    changing = CodeDirectory(db, ttl_s=60.0, bus=two_buses[0])
    other = CodeDirectory(db, ttl_s=60.0, bus=two_buses[1])
    opened = [asyncio.Event(), asyncio.Event()]
    following = [
        asyncio.create_task(codes.follow(event))
        for codes, event in zip((changing, other), opened, strict=True)
    ]
    try:
        for event in opened:
            await event.wait()
        tag = issue(db, "demo", tag_spec(), "test")
        assert (await other.resolve(tag.code)).problem is None
        switch_off(db, tag.code)
        assert (await other.resolve(tag.code)).problem is None, "cached"
        await asyncio.to_thread(changing.forget)  # as the door does, in a worker thread
        async with asyncio.timeout(30):
            while (await other.resolve(tag.code)).problem is None:
                await asyncio.sleep(0.02)
    finally:
        await cancel_and_wait(*following)
