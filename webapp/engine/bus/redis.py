"""The bus of several server processes: each wall's frames in one Redis stream, its
lock a Redis lock."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import AsyncIterator, Callable, Coroutine
from contextlib import asynccontextmanager
from typing import Any, cast

from redis.asyncio import Redis
from redis.asyncio.lock import Lock
from redis.exceptions import LockError, RedisError

from webapp.core.tasks import cancel_and_wait
from webapp.database.redis import redis_key
from webapp.engine.bus.base import (
    EVENTS,
    BusUnavailable,
    EventBus,
    Subscription,
    WallBusy,
)

log = logging.getLogger(__name__)

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
