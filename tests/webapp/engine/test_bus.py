"""The event bus, in memory and on Redis Streams (a real Redis, a key prefix per test).

Two ``RedisBus`` instances with clients of their own stand for two server processes.
"""

from __future__ import annotations

import ast
import asyncio
import contextlib
import json
import logging
from collections.abc import AsyncIterator, Callable

import pytest
from redis.asyncio import Redis
from redis.asyncio.lock import Lock
from redis.exceptions import RedisError

from tests.cable import Cable
from tests.conftest import migrate
from webapp.core.settings import PROJECT_ROOT
from webapp.database.connection import Database
from webapp.database.redis import connect_redis
from webapp.engine.bus.base import (
    BusUnavailable,
    EventBus,
    SubscriberTooSlow,
    Subscription,
    WallBusy,
    run_now,
)
from webapp.engine.bus.memory import MemoryBus
from webapp.engine.bus.redis import RedisBus, _WallReader, lock_key, stream_key
from webapp.engine.hub import WallHub
from webapp.engine.wall_state import StatePatch

MakeBus = Callable[..., EventBus]
BOUND_S = 30  # what "soon" means on a loaded machine; the tests prove order, not speed


@pytest.fixture(params=["memory", "redis"])
async def make_bus(request: pytest.FixtureRequest) -> AsyncIterator[MakeBus]:
    """Buses of the kind under test; Redis ones share this test's Redis and prefix, as
    the processes of one installation do."""
    made: list[EventBus] = []
    if request.param == "redis":
        url, prefix = (
            request.getfixturevalue("redis_server"),
            request.getfixturevalue("redis_prefix"),
        )

    def make(queue_size: int = 8) -> EventBus:
        bus: EventBus
        if request.param == "memory":
            bus = MemoryBus(queue_size)
        else:
            bus = RedisBus(connect_redis(url), prefix, queue_size=queue_size, max_len=100)
        made.append(bus)
        return bus

    yield make
    for bus in made:
        await close(bus)


@pytest.fixture
async def redis_buses(redis_server: str, redis_prefix: str) -> AsyncIterator[MakeBus]:
    """Redis buses on this test's prefix: ``make(url=..., name=..., **options)``."""
    made: list[RedisBus] = []

    def make(url: str = redis_server, name: str = "tagwall", **options: float) -> RedisBus:
        settings: dict[str, float] = {"queue_size": 64, "max_len": 100, **options}
        bus = RedisBus(
            connect_redis(url, client_name=name),
            redis_prefix,
            queue_size=int(settings.pop("queue_size")),
            max_len=int(settings.pop("max_len")),
            **settings,
        )
        made.append(bus)
        return bus

    yield make
    for bus in made:
        await close(bus)


async def close(bus: EventBus) -> None:
    """Close a bus and, for Redis, the client the test made for it."""
    await bus.close()
    if isinstance(bus, RedisBus):
        with contextlib.suppress(RedisError, OSError):
            await bus.redis.aclose()


@pytest.fixture
async def admin(redis_server: str) -> AsyncIterator[Redis]:
    """A client of the test's own, for what an operator (or a crash) does to Redis."""
    client = connect_redis(redis_server, client_name="test-admin")
    yield client
    await client.aclose()


async def receive(subscription: Subscription, count: int) -> list[str]:
    async with asyncio.timeout(BOUND_S):
        return [await subscription.next() for _ in range(count)]


async def soon(condition: Callable[[], bool]) -> None:
    async with asyncio.timeout(BOUND_S):
        while not condition():
            await asyncio.sleep(0.02)


# --- writing on the publisher's turn ---------------------------------------------


class Socket:
    """A connection's writes as ``Subscription.write_through`` sees them: in order
    (a FIFO lock), waiting while the socket pushes back (``writable`` clear)."""

    def __init__(self) -> None:
        self.written: list[str] = []
        self.writable = asyncio.Event()
        self.writable.set()
        self.lock = asyncio.Lock()
        self.broken = False

    async def write(self, message: str) -> None:
        async with self.lock:
            await self.writable.wait()
            if self.broken:
                raise ConnectionResetError("the peer went away")
            self.written.append(message)

    async def write_queued(self, subscription: Subscription) -> None:
        """The connection's own loop: writes what queued while a write waited."""
        while True:
            await self.write(await subscription.next())


async def test_run_now_finishes_a_coroutine_that_never_waits_on_the_callers_turn() -> None:
    done: list[str] = []

    async def work() -> None:
        done.append("done")

    assert run_now(work()) is None
    assert done == ["done"]


async def test_run_now_carries_on_from_the_first_wait_in_a_task() -> None:
    steps: list[str] = []
    go_on = asyncio.Event()

    async def work() -> None:
        steps.append("before")
        await go_on.wait()
        await asyncio.sleep(0)
        steps.append("after")

    rest = run_now(work())
    assert steps == ["before"] and rest is not None
    go_on.set()
    async with asyncio.timeout(BOUND_S):
        await rest
    assert steps == ["before", "after"]


@pytest.mark.parametrize("steps_before_cancel", [1, 0])  # 0: the task never took a step
async def test_run_now_passes_cancellation_to_the_waiting_coroutine(
    steps_before_cancel: int,
) -> None:
    lock, seen = asyncio.Lock(), []

    async def work() -> None:
        async with lock:
            try:
                await asyncio.Event().wait()
            except asyncio.CancelledError:
                seen.append("cancelled")
                raise

    rest = run_now(work())
    assert rest is not None and lock.locked()
    for _ in range(steps_before_cancel):
        await asyncio.sleep(0)
    rest.cancel()
    with pytest.raises(asyncio.CancelledError):
        await rest
    assert seen == ["cancelled"] and not lock.locked()


async def test_run_now_raises_what_the_coroutine_raised_before_waiting() -> None:
    async def work() -> None:
        raise ValueError("bad")

    with pytest.raises(ValueError, match="bad"):
        run_now(work())


async def test_a_writing_subscriber_gets_a_frame_before_other_ready_work() -> None:
    bus, socket = MemoryBus(8), Socket()
    order: list[str] = []
    async with bus.subscribe("a") as subscription:
        subscription.write_through(socket.write)
        asyncio.get_running_loop().call_soon(order.append, "work already ready")
        await bus.publish("a", "frame")
        order.extend(socket.written)
        await asyncio.sleep(0)
    assert order == ["frame", "work already ready"]
    assert subscription.drain() == []  # written, not queued


async def test_frames_published_while_a_write_waits_follow_it_in_order() -> None:
    bus, socket = MemoryBus(8), Socket()
    async with bus.subscribe("a") as subscription:
        subscription.write_through(socket.write)
        writer = asyncio.create_task(socket.write_queued(subscription))
        socket.writable.clear()  # the peer reads slowly
        for index in range(4):
            await bus.publish("a", str(index))
        assert socket.written == []
        socket.writable.set()
        await soon(lambda: len(socket.written) == 4)
        await bus.publish("a", "4")
        assert socket.written == ["0", "1", "2", "3", "4"]  # the last on the publisher's turn
        writer.cancel()


async def test_a_socket_that_keeps_pushing_back_falls_behind() -> None:
    bus, socket = MemoryBus(2), Socket()
    async with bus.subscribe("a") as subscription:
        subscription.write_through(socket.write)
        socket.writable.clear()
        for index in range(4):  # one write waiting, two queued, one too many
            await bus.publish("a", str(index))
        assert subscription.overflowed
        assert [await subscription.next(), await subscription.next()] == ["1", "2"]
        with pytest.raises(SubscriberTooSlow):
            await subscription.next()
        subscription.write_through(None)  # the connection ends: its waiting write goes
        await soon(lambda: not socket.lock.locked())
        socket.writable.set()
        await asyncio.sleep(0)
        assert socket.written == []


@pytest.mark.parametrize("when", ["at once", "after waiting"])
async def test_a_failed_write_ends_that_connection_only(when: str) -> None:
    bus, broken, healthy = MemoryBus(8), Socket(), Socket()
    broken.broken = True
    async with bus.subscribe("a") as failing, bus.subscribe("a") as other:
        failing.write_through(broken.write)
        other.write_through(healthy.write)
        if when == "after waiting":
            broken.writable.clear()
        await bus.publish("a", "frame")  # the publisher never sees the failure
        await bus.publish("a", "queued behind it")
        broken.writable.set()
        assert healthy.written == ["frame", "queued behind it"]
        taken = []  # by the connection's loop before the failure was known
        with pytest.raises(ConnectionResetError):
            async with asyncio.timeout(BOUND_S):
                while True:
                    taken.append(await failing.next())
        assert taken == ([] if when == "at once" else ["queued behind it"])
        await bus.publish("a", "later")
        assert healthy.written == ["frame", "queued behind it", "later"]
        assert broken.written == []


# --- both buses ------------------------------------------------------------------


async def test_publish_reaches_every_subscriber_of_that_wall_only(make_bus: MakeBus) -> None:
    bus = make_bus()
    async with (
        bus.subscribe("a") as first,
        bus.subscribe("a") as second,
        bus.subscribe("b") as other,
    ):
        await bus.publish("a", "hello")
        await bus.publish("b", "marker")
        assert await receive(first, 1) == ["hello"]
        assert await receive(second, 1) == ["hello"]
        assert await receive(other, 1) == ["marker"]  # a's frame would have come first


async def test_messages_arrive_in_publication_order(make_bus: MakeBus) -> None:
    bus = make_bus()
    async with bus.subscribe("a") as subscription:
        for index in range(5):
            await bus.publish("a", str(index))
        assert await receive(subscription, 5) == ["0", "1", "2", "3", "4"]


async def test_slow_subscriber_is_dropped_without_blocking_others(make_bus: MakeBus) -> None:
    bus = make_bus(queue_size=2)
    async with bus.subscribe("a") as slow, bus.subscribe("a") as fast:
        for index in range(4):
            await bus.publish("a", str(index))
            assert await receive(fast, 1) == [str(index)]
        assert slow.overflowed and not fast.overflowed
        assert await slow.next() == "0"
        assert await slow.next() == "1"
        with pytest.raises(SubscriberTooSlow):
            await slow.next()


async def test_leaving_unsubscribes(make_bus: MakeBus) -> None:
    bus = make_bus()
    async with bus.subscribe("a") as staying:
        async with bus.subscribe("a") as leaving:
            pass
        await bus.publish("a", "after")
        assert await receive(staying, 1) == ["after"]
    assert leaving.drain() == []


async def test_the_wall_lock_lets_one_change_in_at_a_time(make_bus: MakeBus) -> None:
    bus = make_bus()
    inside: list[int] = []
    most = 0

    async def change(index: int) -> None:
        nonlocal most
        async with bus.wall_lock("a"):
            inside.append(index)
            most = max(most, len(inside))
            await asyncio.sleep(0.01)
            inside.remove(index)

    async with asyncio.timeout(BOUND_S):
        await asyncio.gather(*(change(index) for index in range(6)))
    assert most == 1


# --- Redis: several processes ------------------------------------------------------


async def test_two_processes_deliver_every_frame_in_publish_order(redis_buses: MakeBus) -> None:
    one, two = redis_buses(), redis_buses()
    async with one.subscribe("a") as first, two.subscribe("a") as second:
        for index in range(20):
            await (one if index % 2 else two).publish("a", str(index))
        expected = [str(index) for index in range(20)]
        assert await receive(first, 20) == expected
        assert await receive(second, 20) == expected


async def test_a_wall_is_read_while_it_has_subscribers(redis_buses: MakeBus) -> None:
    bus: RedisBus = redis_buses()  # type: ignore[assignment]
    async with bus.subscribe("a"), bus.subscribe("a"):
        async with bus.subscribe("b"):
            assert bus.reading == {"a", "b"}
        assert bus.reading == {"a"}
    assert bus.reading == set()


async def test_a_reader_left_while_its_subscriber_is_cancelled_again_is_still_stopped(
    redis_buses: MakeBus, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A connection cancelled twice over (as ``cancel_and_wait`` does) while its wall's
    reader stops does not leave the reader reading Redis for ever: closing the bus
    waits for it."""
    bus: RedisBus = redis_buses()  # type: ignore[assignment]
    readers: list[_WallReader] = []
    slow_start = asyncio.Event()
    stop = _WallReader.stop

    async def slow_stop(reader: _WallReader) -> None:
        readers.append(reader)
        slow_start.set()
        await asyncio.sleep(0.2)  # a Redis slow to answer
        await stop(reader)

    monkeypatch.setattr(_WallReader, "stop", slow_stop)
    entered = asyncio.Event()

    async def connection() -> None:
        async with bus.subscribe("a"):
            entered.set()
            await asyncio.Event().wait()

    task = asyncio.create_task(connection())
    async with asyncio.timeout(BOUND_S):
        await entered.wait()
        task.cancel()
        await slow_start.wait()
        task.cancel()  # again, halfway through the reader's stop
        with pytest.raises(asyncio.CancelledError):
            await task
        await bus.close()
    (reader,) = readers
    assert reader.reading is not None and reader.reading.done()


async def test_concurrent_changes_through_two_processes_arrive_in_version_order(
    redis_buses: MakeBus, database_url: str
) -> None:
    """Two hubs on one database and one Redis change one wall at once, each holding the
    wall as the door does: every subscriber, of either process, sees versions one by
    one, and no two changes were ever inside at once."""
    migrate(database_url)
    hubs = [
        WallHub(
            Database(database_url),
            redis_buses(),
            apply_lead_ms=0,
            swap_timeout_ms=500,
            keep_events=100,
        )
        for _ in range(2)
    ]
    inside = 0
    most = 0

    async def change(hub: WallHub, mode: str) -> None:
        nonlocal inside, most
        async with hub.placing("demo"):
            inside += 1
            most = max(most, inside)
            await hub.commit("demo", StatePatch(mode=mode).apply_to)
            inside -= 1

    async with hubs[0].bus.subscribe("demo") as first, hubs[1].bus.subscribe("demo") as second:
        async with asyncio.timeout(BOUND_S * 2):
            await asyncio.gather(
                *(change(hub, f"{n}-{i}") for i in range(10) for n, hub in enumerate(hubs))
            )
        for inbox in (first, second):
            frames = [json.loads(frame) for frame in await receive(inbox, 20)]
            assert [frame["version"] for frame in frames] == list(range(1, 21))
    assert most == 1
    for hub in hubs:
        await hub.close()
        hub.db.dispose()


# --- Redis: connections lost ----------------------------------------------------------


async def kill_connections(admin: Redis, name: str) -> int:
    """CLIENT KILL every connection named ``name`` (as Redis does to idle or evicted
    clients, or a restart to all)."""
    killed = 0
    for client in await admin.client_list():
        if client.get("name") == name:
            killed += await admin.client_kill_filter(_id=client["id"])
    return killed


@pytest.mark.parametrize("how", ["client kill", "pool closed"])
async def test_a_reader_resumes_after_its_connection_is_lost(
    redis_buses: MakeBus, admin: Redis, redis_prefix: str, how: str
) -> None:
    name = f"reader-{redis_prefix}"
    reader: RedisBus = redis_buses(name=name)  # type: ignore[assignment]
    publisher = redis_buses()
    async with reader.subscribe("a") as inbox:
        for index in range(5):
            await publisher.publish("a", str(index))
        assert await receive(inbox, 5) == ["0", "1", "2", "3", "4"]
        if how == "client kill":
            assert await kill_connections(admin, name) >= 1
        else:
            await reader.redis.connection_pool.disconnect()
        for index in range(5, 10):
            await publisher.publish("a", str(index))
        await publisher.publish("a", "end")
        assert await receive(inbox, 6) == ["5", "6", "7", "8", "9", "end"]
        assert inbox.drain() == [] and not inbox.overflowed


async def cable_cut(cable: Cable, caplog: pytest.LogCaptureFixture) -> None:
    """Cut ``cable`` and wait until its reader noticed, and tried again more than once."""
    cable.cut()
    await soon(lambda: "lost the event bus" in caplog.text)
    dropped = cable.dropped
    await soon(lambda: cable.dropped > dropped + 8)  # several reconnections refused


async def test_a_reader_rides_out_an_outage_and_says_so_once(
    redis_buses: MakeBus, redis_cable: Cable, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "webapp.engine.bus")
    reader, publisher = redis_buses(url=redis_cable.url), redis_buses()
    async with reader.subscribe("a") as inbox:
        await publisher.publish("a", "before")
        assert await receive(inbox, 1) == ["before"]
        await cable_cut(redis_cable, caplog)
        for index in range(3):
            await publisher.publish("a", f"during {index}")
        redis_cable.mend()
        await publisher.publish("a", "after")
        assert await receive(inbox, 4) == ["during 0", "during 1", "during 2", "after"]
        assert not inbox.overflowed
    assert caplog.text.count("lost the event bus") == 1
    assert caplog.text.count("the event bus is back") == 1


@pytest.mark.parametrize("loss", ["trimmed", "stream gone"])
async def test_a_reader_that_lost_frames_has_its_subscribers_resynchronise(
    redis_buses: MakeBus,
    redis_cable: Cable,
    admin: Redis,
    redis_prefix: str,
    caplog: pytest.LogCaptureFixture,
    loss: str,
) -> None:
    """While the reader was away the stream was trimmed past its position, or went
    (Redis restarted empty): it cannot say what its tiles missed, so they are told to
    resynchronise (their sockets close and they come back with ``hello``)."""
    reader = redis_buses(url=redis_cable.url, max_len=10)
    publisher = redis_buses(max_len=10)
    async with reader.subscribe("a") as inbox:
        await publisher.publish("a", "before")
        assert await receive(inbox, 1) == ["before"]
        await cable_cut(redis_cable, caplog)
        if loss == "trimmed":  # Redis trims whole nodes of 100 entries
            for index in range(350):
                await publisher.publish("a", str(index))
            assert await admin.xlen(stream_key(redis_prefix, "a")) < 350
        else:
            await admin.delete(stream_key(redis_prefix, "a"))
        redis_cable.mend()
        async with asyncio.timeout(BOUND_S):
            with pytest.raises(SubscriberTooSlow):
                await inbox.next()
        async with reader.subscribe("a") as newcomer:
            await publisher.publish("a", "later")
            assert await receive(newcomer, 1) == ["later"]
    assert "lost frames" in caplog.text


async def test_without_redis_publishing_and_subscribing_fail_clearly(
    redis_buses: MakeBus, redis_cable: Cable
) -> None:
    bus = redis_buses(url=redis_cable.url)
    redis_cable.cut()
    with pytest.raises(BusUnavailable):
        await bus.publish("a", "lost")
    with pytest.raises(BusUnavailable):
        async with bus.subscribe("a"):
            pass
    with pytest.raises(BusUnavailable):
        async with bus.wall_lock("a"):
            pass
    redis_cable.mend()
    async with bus.subscribe("a") as inbox:
        await bus.publish("a", "back")
        assert await receive(inbox, 1) == ["back"]


# --- Redis: the wall's lock ---------------------------------------------------------


async def test_the_wall_lock_lapses_when_its_holder_vanished(
    redis_buses: MakeBus, admin: Redis, redis_prefix: str
) -> None:
    """A process killed while holding a wall renews its lock no more: the next change
    gets the wall once it lapses, instead of waiting forever."""
    vanished = Lock(admin, lock_key(redis_prefix, "a"), timeout=1, thread_local=False)
    assert await vanished.acquire(blocking=False)
    bus = redis_buses(lock_wait_s=BOUND_S)
    async with asyncio.timeout(BOUND_S * 2), bus.wall_lock("a"):
        assert not await vanished.owned()


async def test_a_change_waiting_too_long_for_its_wall_gets_a_clear_error(
    redis_buses: MakeBus,
) -> None:
    """A live holder renews its lock (the wait outlasts the lock's expiry), so the other
    process's change gives up with ``WallBusy`` rather than hang or barge in."""
    holder, waiter = redis_buses(lock_expiry_s=2), redis_buses(lock_wait_s=5)
    release = asyncio.Event()
    held = asyncio.Event()

    async def hold() -> None:
        async with holder.wall_lock("a"):
            held.set()
            await release.wait()

    holding = asyncio.create_task(hold())
    await asyncio.wait_for(held.wait(), BOUND_S)
    with pytest.raises(WallBusy, match="wall a was held by another change"):
        async with asyncio.timeout(BOUND_S), waiter.wall_lock("a"):
            pass
    release.set()
    await holding
    async with asyncio.timeout(BOUND_S), waiter.wall_lock("a"):
        pass


def test_only_the_hub_takes_a_walls_lock() -> None:
    """One home for holding a wall: the door asks the hub (``placing``), the hub asks
    the bus; nothing else takes ``wall_lock``."""
    webapp = PROJECT_ROOT / "webapp"
    takers = {
        path.relative_to(webapp).as_posix()
        for path in webapp.rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.Attribute) and node.attr == "wall_lock"
    }
    assert takers == {"engine/hub.py"}
