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
import logging
from abc import ABC, abstractmethod
from collections.abc import Callable, Coroutine
from contextlib import AbstractAsyncContextManager
from typing import Any

from webapp.core.tasks import run_now

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
