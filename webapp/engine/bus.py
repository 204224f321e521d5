"""Event bus: fans a wall's events out to every connection that shows the wall.

Messages travel as serialised JSON text, encoded once per event however many
tiles receive it. Each subscription has a bounded queue; a subscriber that falls
behind is marked overflowed and dropped by its connection, and the tile
resynchronises by snapshot instead of slowing everyone down.

A wall has channels: ``events`` (the frames tiles receive) and others the processes
sharing a wall tell each other on (:mod:`webapp.engine.hub`: ``tiles``; scans, codes),
each delivered in its own publication order, by the same code on either bus.

The bus also holds each wall while a change is made (:meth:`EventBus.wall_lock`):
publication order is version order only if changes of one wall never overlap, in one
process (:class:`MemoryBus`) or in all that share the wall (:class:`RedisBus`).
"""

from __future__ import annotations

import asyncio
import functools
import inspect
import logging
import types
from abc import ABC, abstractmethod
from collections.abc import AsyncIterator, Callable, Coroutine, Generator
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Any, cast

from redis.asyncio import Redis
from redis.asyncio.lock import Lock
from redis.exceptions import LockError, RedisError

from webapp.database.redis import redis_key

log = logging.getLogger(__name__)


class SubscriberTooSlow(Exception):
    """The subscriber fell behind (a whole queue, or frames the bus lost); its connection
    must resynchronise."""


class BusUnavailable(Exception):
    """The shared bus (Redis) did not answer; try again in a moment."""


class WallBusy(Exception):
    """Another change held the wall for longer than a change waits for it."""


Write = Callable[[str], Coroutine[Any, Any, None]]
"""How a connection writes one message to its socket."""


class Subscription:
    """One connection's bounded inbox for one wall.

    A connection that can write on the publisher's turn (:meth:`write_through`) gets each
    message written as it is offered, while nothing is queued before it: a published
    frame reaches the tiles ahead of whatever else is ready to run on the event loop,
    without a task switch per tile. What arrives while a write waits (a socket that
    pushes back) queues, in order, for the connection's own loop (:meth:`next`).
    """

    def __init__(self, maxsize: int) -> None:
        self.maxsize = maxsize
        # Unbounded underneath so the overflow marker always fits; ``offer`` bounds it.
        self._queue: asyncio.Queue[str | None] = asyncio.Queue()
        self.overflowed = False
        self._write: Write | None = None
        self._writing: asyncio.Task[None] | None = None
        self._failure: Exception | None = None

    def write_through(self, write: Write | None) -> None:
        """Write each message offered from now on with ``write`` when nothing is queued
        or being written before it (``None``: stop, and abandon a write still waiting).
        The connection's ``write`` must keep its own writes in order (a FIFO lock), so
        that one started here and one of :meth:`next`'s messages never swap places."""
        if write is None and self._writing is not None:
            self._writing.cancel()
        self._write = write

    def offer(self, message: str) -> None:
        """Write ``message`` now (see :meth:`write_through`), or queue it, or mark the
        subscriber as too slow to keep."""
        if self.overflowed:
            return
        if self._write is not None and self._writing is None and self._queue.empty():
            self._write_now(self._write, message)
        elif self._queue.qsize() >= self.maxsize:
            self.fall_behind()
        else:
            self._queue.put_nowait(message)

    def _write_now(self, write: Write, message: str) -> None:
        try:
            self._writing = run_now(write(message))
        except Exception as error:  # one socket's failure is its connection's, not the publisher's
            self._fail(error)
            return
        if self._writing is not None:
            self._writing.add_done_callback(self._written)

    def _written(self, writing: asyncio.Task[None]) -> None:
        self._writing = None
        if not writing.cancelled() and isinstance(error := writing.exception(), Exception):
            self._fail(error)

    def _fail(self, error: Exception) -> None:
        """A write failed: :meth:`next` raises ``error`` next (what is queued would go
        to a socket that is gone)."""
        self._failure = error
        self.overflowed = True
        self.drain()
        self._queue.put_nowait(None)

    def fall_behind(self) -> None:
        """Mark the subscriber as having missed messages: after what is queued,
        ``next`` raises ``SubscriberTooSlow`` and the connection resynchronises."""
        if not self.overflowed:
            self.overflowed = True
            self._queue.put_nowait(None)

    async def next(self) -> str:
        """The next queued message; raises ``SubscriberTooSlow`` once the queue overflowed,
        or what a write on the publisher's turn raised."""
        message = await self._queue.get()
        if message is None:
            raise self._failure or SubscriberTooSlow()
        return message

    def drain(self) -> list[str]:
        """Take every message queued so far without waiting (to inspect an inbox)."""
        messages = []
        while not self._queue.empty():
            message = self._queue.get_nowait()
            if message is not None:
                messages.append(message)
        return messages


def run_now(coroutine: Coroutine[Any, Any, None]) -> asyncio.Task[None] | None:
    """Run ``coroutine`` on the caller's turn up to its first wait: ``None`` when it
    finished there, otherwise a task that carries on from that wait (what Python 3.12's
    eager tasks do). Raises what the coroutine raised before waiting."""
    try:
        awaited = coroutine.send(None)
    except StopIteration:
        return None
    rest = asyncio.get_running_loop().create_task(_carry_on(coroutine, awaited))
    rest.add_done_callback(lambda _: _unwind(coroutine))
    return rest


def _unwind(coroutine: Coroutine[Any, Any, None]) -> None:
    """A task cancelled before its first step never resumed its coroutine: throw the
    cancellation in, so that its waits and locks let go of it."""
    if inspect.getcoroutinestate(coroutine) != inspect.CORO_SUSPENDED:  # it ran to its end
        return
    try:
        coroutine.throw(asyncio.CancelledError())
    except (asyncio.CancelledError, StopIteration):
        return
    except Exception:
        log.exception("a write abandoned by its task failed as it unwound")
        return
    coroutine.close()  # it waited again: abandon it there


async def _carry_on(coroutine: Coroutine[Any, Any, None], awaited: Any) -> None:
    await _resume(coroutine, awaited)


@types.coroutine
def _resume(coroutine: Coroutine[Any, Any, None], awaited: Any) -> Generator[Any, Any, None]:
    """Hand a started coroutine's waits to the task awaiting this, and its wake-ups
    (or cancellation) back to the coroutine, until it returns."""
    while True:
        try:
            yield awaited
        except BaseException as error:  # the task's cancellation, passed on
            resume = functools.partial(coroutine.throw, error)
        else:
            resume = functools.partial(coroutine.send, None)
        try:
            awaited = resume()
        except StopIteration:
            return


EVENTS = "events"
"""The channel of the frames tiles receive (``publish``/``subscribe``'s default)."""


class EventBus(ABC):
    """Where published wall events go; implementations: memory (one process), Redis."""

    def __init__(self, queue_size: int) -> None:
        self.queue_size = queue_size
        self._process_locks: dict[str, asyncio.Lock] = {}

    @abstractmethod
    async def publish(self, wall_id: str, message: str, channel: str = EVENTS) -> None:
        """Deliver ``message`` to every current subscriber of ``wall_id``'s ``channel``;
        raises ``BusUnavailable`` when it cannot."""

    @abstractmethod
    def subscribe(
        self, wall_id: str, channel: str = EVENTS
    ) -> AbstractAsyncContextManager[Subscription]:
        """Context manager: a subscription that receives every message published on
        ``wall_id``'s ``channel`` after it was entered, until the block exits; entering
        raises ``BusUnavailable`` when the bus cannot be reached."""

    @abstractmethod
    def wall_lock(self, wall_id: str) -> AbstractAsyncContextManager[None]:
        """Context manager holding ``wall_id`` against every other change of it that
        this bus's subscribers can see (the door holds it through a whole change)."""

    def _process_lock(self, wall_id: str) -> asyncio.Lock:
        """The wall's lock within this process."""
        return self._process_locks.setdefault(wall_id, asyncio.Lock())

    async def close(self) -> None:  # noqa: B027 - optional hook, nothing to release in memory
        """Release connections held by the bus."""


class MemoryBus(EventBus):
    """In-process fan-out, for a single server process."""

    def __init__(self, queue_size: int) -> None:
        super().__init__(queue_size)
        self._subscribers: dict[tuple[str, str], set[Subscription]] = {}

    async def publish(self, wall_id: str, message: str, channel: str = EVENTS) -> None:
        for subscription in tuple(self._subscribers.get((wall_id, channel), ())):
            subscription.offer(message)

    @asynccontextmanager
    async def subscribe(self, wall_id: str, channel: str = EVENTS) -> AsyncIterator[Subscription]:
        subscription = Subscription(self.queue_size)
        subscribers = self._subscribers.setdefault((wall_id, channel), set())
        subscribers.add(subscription)
        try:
            yield subscription
        finally:
            subscribers.discard(subscription)
            if not subscribers:
                self._subscribers.pop((wall_id, channel), None)

    def wall_lock(self, wall_id: str) -> asyncio.Lock:
        """One process is every publisher there is: its own lock is enough."""
        return self._process_lock(wall_id)


FOLLOW_RETRY_S = 1.0
"""A follower whose bus did not answer subscribes again after this long."""


async def follow(
    bus: EventBus,
    wall_id: str,
    channel: str,
    handle: Callable[[str], None],
    opened: asyncio.Event | None = None,
) -> None:
    """Hand every message of ``wall_id``'s ``channel`` to ``handle`` until cancelled: how a
    process listens to what the others say (tile presence, scans, codes). ``opened`` is
    set once the first subscription was tried. A follower that fell behind or could not
    subscribe subscribes again (what it missed meanwhile is lost: what it follows is
    repeated or expires). A message ``handle`` cannot take is logged and skipped."""
    while True:
        try:
            async with bus.subscribe(wall_id, channel) as inbox:
                if opened is not None:
                    opened.set()
                while True:
                    message = await inbox.next()
                    try:
                        handle(message)
                    except Exception:
                        log.exception("wall %s: could not take a %s message", wall_id, channel)
        except SubscriberTooSlow:
            log.warning("wall %s: fell behind on %s; following again", wall_id, channel)
        except BusUnavailable as error:
            if opened is not None:
                opened.set()
            log.warning("wall %s: cannot follow %s (%s); trying again", wall_id, channel, error)
            await asyncio.sleep(FOLLOW_RETRY_S)


# --- Redis Streams ----------------------------------------------------------------

StreamId = tuple[int, int]
StreamReply = list[tuple[bytes, list[tuple[bytes, dict[bytes, bytes]]]]] | None
"""What XREAD answers (RESP2, bytes): per stream, its entries as (id, fields)."""
FIRST_ID = b"0-0"
FRAME_FIELD = b"frame"  # the one field of a stream entry: the frame as tiles receive it

READ_BLOCK_MS = 5_000
"""How long one XREAD waits for new entries (well under the client's socket timeout)."""
READ_COUNT = 512
RECONNECT_FIRST_S = 0.1
RECONNECT_MAX_S = 5.0
"""A reader cut off from Redis tries again after 0.1 s, doubling up to 5 s."""
WALL_LOCK_EXPIRY_S = 10.0
"""A wall's cross-process lock lapses this long after its holder stops renewing it: a
killed process blocks its walls for at most this long."""
WALL_LOCK_WAIT_S = 30.0
"""How long a change waits for its wall before it gives up with ``WallBusy``."""
WALL_LOCK_POLL_S = 0.02


def stream_key(prefix: str, wall_id: str, channel: str = EVENTS) -> str:
    """The Redis stream holding ``wall_id``'s ``channel``, in publication order."""
    return redis_key(prefix, "wall", wall_id, channel)


def lock_key(prefix: str, wall_id: str) -> str:
    """The Redis key of ``wall_id``'s cross-process lock."""
    return redis_key(prefix, "wall", wall_id, "lock")


def _stream_id(raw: bytes | str) -> StreamId:
    text = raw.decode() if isinstance(raw, bytes) else raw
    milliseconds, _, sequence = text.partition("-")
    return int(milliseconds), int(sequence or 0)


class _WallReader:
    """This process's reader of one wall's channel (a stream), for its local subscribers.

    ``position`` is the id of the last entry delivered (or the stream's end when the
    reader started): reading resumes after it, so a dropped connection loses and
    repeats nothing while the stream still holds the entries. ``through`` counts the
    entries ever added to the stream up to ``position``, to tell after an outage
    whether entries past it were trimmed away (see :meth:`RedisBus._resume`).
    """

    def __init__(
        self,
        wall_id: str,
        channel: str,
        start: Callable[[_WallReader], Coroutine[Any, Any, None]],
    ) -> None:
        self.wall_id = wall_id
        self.channel = channel
        self.subscriptions: set[Subscription] = set()
        self.position = FIRST_ID
        self.through = 0
        self.reading: asyncio.Task[None] | None = None
        self.opening = asyncio.create_task(start(self))

    def offer(self, frame: str) -> None:
        for subscription in tuple(self.subscriptions):
            subscription.offer(frame)

    async def stop(self) -> None:
        await cancel_and_wait(*(task for task in (self.opening, self.reading) if task is not None))


async def cancel_and_wait(*tasks: asyncio.Task[None]) -> None:
    """Cancel ``tasks`` and wait for them to end, cancelling again while one carries on:
    Python 3.11's ``asyncio.wait_for`` (which redis-py sends through) drops a
    cancellation that arrives as the send completes."""
    while pending := [task for task in tasks if not task.done()]:
        for task in pending:
            task.cancel()
        await asyncio.wait(pending, timeout=0.1)
    for task in tasks:
        if not task.cancelled():
            task.exception()  # retrieved: whoever awaited it has seen it


class RedisBus(EventBus):
    """Fan-out across processes: each wall's frames in one Redis stream.

    Publishing appends the frame (XADD); each process runs one reader per wall it has
    subscribers of, blocking on XREAD after the last entry it delivered and offering
    every frame to its local subscriptions. A stream delivers every entry to every
    reader in one order, at least once, where Pub/Sub would drop whatever is sent
    while a connection is down.

    The stream is capped (approximately, which lets Redis trim whole nodes cheaply) at
    about ``max_len`` entries, as many frames as the database keeps events
    (``TAGWALL_EVENT_HISTORY``): a stream is not the history, it only has to cover what a
    reader misses while its connection is down, and uncapped it would grow with every
    change forever. A tile further behind catches up from the database's event table or
    a snapshot (``hello``), as it always did.
    """

    def __init__(
        self,
        redis: Redis,
        prefix: str,
        *,
        queue_size: int,
        max_len: int,
        lock_expiry_s: float = WALL_LOCK_EXPIRY_S,
        lock_wait_s: float = WALL_LOCK_WAIT_S,
    ) -> None:
        super().__init__(queue_size)
        self.redis = redis
        self.prefix = prefix
        self.max_len = max_len
        self.lock_expiry_s = lock_expiry_s
        self.lock_wait_s = lock_wait_s
        self._readers: dict[tuple[str, str], _WallReader] = {}
        self._stopping: set[asyncio.Future[None]] = set()  # readers whose last subscriber left

    @property
    def reading(self) -> frozenset[str]:
        """The walls whose events this process reads, having subscribers of them."""
        return frozenset(wall for wall, channel in self._readers if channel == EVENTS)

    async def publish(self, wall_id: str, message: str, channel: str = EVENTS) -> None:
        try:
            await self.redis.xadd(
                stream_key(self.prefix, wall_id, channel),
                {FRAME_FIELD: message},
                maxlen=self.max_len,
                approximate=True,
            )
        except RedisError as error:
            raise BusUnavailable(f"Redis did not take wall {wall_id}'s frame: {error}") from error

    @asynccontextmanager
    async def subscribe(self, wall_id: str, channel: str = EVENTS) -> AsyncIterator[Subscription]:
        name = (wall_id, channel)
        reader = self._readers.get(name)
        if reader is None:
            reader = self._readers[name] = _WallReader(wall_id, channel, self._open)
        subscription = Subscription(self.queue_size)
        reader.subscriptions.add(subscription)
        try:
            # Every subscriber waits until the reader knows where the stream ends, so it
            # receives whatever is published after it subscribed.
            await asyncio.shield(reader.opening)
            yield subscription
        finally:
            reader.subscriptions.discard(subscription)
            if not reader.subscriptions and self._readers.get(name) is reader:
                del self._readers[name]
                await self._stop(reader)

    async def _open(self, reader: _WallReader) -> None:
        """Start ``reader`` at the stream's current end."""
        try:
            info = await self._stream_info(reader)
        except RedisError as error:
            raise BusUnavailable(f"Redis did not open wall {reader.wall_id}: {error}") from error
        if info is not None:
            reader.position = info["last-generated-id"]
            reader.through = int(info.get("entries-added", 0))
        reader.reading = asyncio.create_task(self._read(reader))

    async def _stream_info(self, reader: _WallReader) -> dict[str, Any] | None:
        key = stream_key(self.prefix, reader.wall_id, reader.channel)
        if not await self.redis.exists(key):
            return None
        info: dict[str, Any] = await self.redis.xinfo_stream(key)
        return info

    async def _read(self, reader: _WallReader) -> None:
        """Deliver the wall's frames to the local subscribers until stopped; reconnect
        after an outage (logged once) and resume where reading stopped."""
        key = stream_key(self.prefix, reader.wall_id, reader.channel)
        delay = RECONNECT_FIRST_S
        away = False
        while True:
            try:
                if away:
                    await self._resume(reader)
                reply = cast(  # the client speaks RESP2 and leaves replies as bytes
                    StreamReply,
                    await self.redis.xread(
                        {key: reader.position}, count=READ_COUNT, block=READ_BLOCK_MS
                    ),
                )
            except RedisError as error:
                if not away:
                    away = True
                    log.warning(
                        "wall %s: lost the event bus (%s: %s); reconnecting, frames will "
                        "resume after %s",
                        reader.wall_id,
                        type(error).__name__,
                        error,
                        reader.position.decode(),
                    )
                await asyncio.sleep(delay)
                delay = min(delay * 2, RECONNECT_MAX_S)
                continue
            if away:
                log.info("wall %s: the event bus is back", reader.wall_id)
                away, delay = False, RECONNECT_FIRST_S
            for _key, entries in reply or ():
                for entry_id, fields in entries:
                    reader.offer(fields[FRAME_FIELD].decode())
                    reader.position = entry_id
                    reader.through += 1

    async def _resume(self, reader: _WallReader) -> None:
        """After an outage: carry on from ``reader.position`` when the stream still
        holds every entry after it. Otherwise (trimmed past it while the reader was
        away, or lost in a Redis restart) the reader cannot vouch for what its
        subscribers missed: each is marked as fallen behind, so its connection closes
        and the tile comes back with ``hello(last_version)`` for the missed events from
        the database or a snapshot, and reading carries on from the stream's end."""
        info = await self._stream_info(reader)
        if info is None:  # the stream is gone (Redis restarted empty)
            lost = reader.through > 0
            end, added = FIRST_ID, 0
        else:
            lost = self._trimmed_past(reader, info)
            end, added = info["last-generated-id"], int(info.get("entries-added") or 0)
        if info is None or lost:
            reader.position, reader.through = end, added
        if not lost:
            return
        log.warning(
            "wall %s: the event stream lost frames while this process was away; its %d "
            "local subscribers resynchronise",
            reader.wall_id,
            len(reader.subscriptions),
        )
        for subscription in tuple(reader.subscriptions):
            subscription.fall_behind()

    @staticmethod
    def _trimmed_past(reader: _WallReader, info: dict[str, Any]) -> bool:
        """Whether entries after ``reader.position`` are missing from the stream.

        Redis 7 counts the entries ever added: those trimmed are the count less the
        length, and all of them are at or before the position exactly when that is at
        most ``through``. A count below ``through`` (or a last id below the position)
        means the stream was made anew. Older Redis: the first entry still there must be
        at or before the position.
        """
        position = _stream_id(reader.position)
        if _stream_id(info["last-generated-id"]) < position:
            return True
        added = info.get("entries-added")
        if added is not None:
            added = int(added)
            return added < reader.through or added - int(info["length"]) > reader.through
        first = info.get("first-entry")
        return first is None or _stream_id(first[0]) > position

    @asynccontextmanager
    async def wall_lock(self, wall_id: str) -> AsyncIterator[None]:
        """This process's lock, then the wall's lock in Redis (queued locally first, so
        one process's changes do not all poll Redis). The Redis lock lapses
        ``lock_expiry_s`` after its holder stops renewing it, so a killed process holds
        nothing for long; a change waits ``lock_wait_s`` at most, then ``WallBusy``."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.lock_wait_s
        local = self._process_lock(wall_id)
        try:
            async with asyncio.timeout_at(deadline):
                await local.acquire()
        except TimeoutError:
            raise self._busy(wall_id) from None
        try:
            lock = Lock(
                self.redis,
                lock_key(self.prefix, wall_id),
                timeout=self.lock_expiry_s,
                sleep=WALL_LOCK_POLL_S,
                blocking_timeout=max(0.0, deadline - loop.time()),
                thread_local=False,
            )
            try:
                held = await lock.acquire()
            except RedisError as error:
                raise BusUnavailable(f"Redis did not lock wall {wall_id}: {error}") from error
            if not held:
                raise self._busy(wall_id)
            renewing = asyncio.create_task(self._keep_held(lock, wall_id))
            try:
                yield
            finally:
                await cancel_and_wait(renewing)
                await self._let_go(lock, wall_id)
        finally:
            local.release()

    def _busy(self, wall_id: str) -> WallBusy:
        return WallBusy(
            f"wall {wall_id} was held by another change for more than {self.lock_wait_s:g} s"
        )

    async def _keep_held(self, lock: Lock, wall_id: str) -> None:
        """Renew the lock while its change runs (settling an app may take a while)."""
        while True:
            await asyncio.sleep(self.lock_expiry_s / 3)
            try:
                await lock.reacquire()
            except LockError:
                log.error(
                    "wall %s: the wall's lock lapsed during a change (not renewed within "
                    "%g s); another process may change the wall meanwhile",
                    wall_id,
                    self.lock_expiry_s,
                )
                return
            except RedisError as error:
                log.warning("wall %s: could not renew the wall's lock: %s", wall_id, error)

    @staticmethod
    async def _let_go(lock: Lock, wall_id: str) -> None:
        """Release the lock; one that lapsed or a Redis that is gone is only logged (the
        change is made; the lock expires by itself)."""
        try:
            await lock.release()
        except (LockError, RedisError) as error:
            log.warning("wall %s: could not release the wall's lock: %s", wall_id, error)

    async def close(self) -> None:
        """Stop reading; the client belongs to whoever made it (the app factory)."""
        readers = list(self._readers.values())
        self._readers.clear()
        for reader in readers:
            await reader.stop()
        while self._stopping:  # not gather: cancelling close must not cut a stop short
            await asyncio.wait(set(self._stopping))

    async def _stop(self, reader: _WallReader) -> None:
        """Stop a reader its last subscriber left. The stop outlives that subscriber's
        own cancellation (a connection closed twice over), and :meth:`close` waits for
        it: a reader cut off halfway would read Redis for ever."""
        stopping = asyncio.ensure_future(reader.stop())
        self._stopping.add(stopping)
        stopping.add_done_callback(self._stopping.discard)
        await asyncio.shield(stopping)
