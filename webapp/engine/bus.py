"""Event bus: fans a wall's events out to every connection that shows the wall.

Messages travel as serialised JSON text, encoded once per event however many
tiles receive it. Each subscription has a bounded queue; a subscriber that falls
behind is marked overflowed and dropped by its connection, and the tile
resynchronises by snapshot instead of slowing everyone down.
"""

from __future__ import annotations

import asyncio
from abc import ABC, abstractmethod
from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager, asynccontextmanager


class SubscriberTooSlow(Exception):
    """The subscriber fell a whole queue behind; its connection must resynchronise."""


class Subscription:
    """One connection's bounded inbox for one wall."""

    def __init__(self, maxsize: int) -> None:
        self.maxsize = maxsize
        # Unbounded underneath so the overflow marker always fits; ``offer`` bounds it.
        self._queue: asyncio.Queue[str | None] = asyncio.Queue()
        self.overflowed = False

    def offer(self, message: str) -> None:
        """Queue ``message``, or mark the subscriber as too slow to keep."""
        if self.overflowed:
            return
        if self._queue.qsize() >= self.maxsize:
            self.overflowed = True
            self._queue.put_nowait(None)
        else:
            self._queue.put_nowait(message)

    async def next(self) -> str:
        """The next message; raises ``SubscriberTooSlow`` once the queue overflowed."""
        message = await self._queue.get()
        if message is None:
            raise SubscriberTooSlow
        return message

    def drain(self) -> list[str]:
        """Take every message queued so far without waiting (to inspect an inbox)."""
        messages = []
        while not self._queue.empty():
            message = self._queue.get_nowait()
            if message is not None:
                messages.append(message)
        return messages


class EventBus(ABC):
    """Where published wall events go; implementations: memory (one process), Redis."""

    def __init__(self, queue_size: int) -> None:
        self.queue_size = queue_size

    @abstractmethod
    async def publish(self, wall_id: str, message: str) -> None:
        """Deliver ``message`` to every current subscriber of ``wall_id``."""

    @abstractmethod
    def subscribe(self, wall_id: str) -> AbstractAsyncContextManager[Subscription]:
        """Context manager: a subscription that receives until the block exits."""

    async def close(self) -> None:  # noqa: B027 - optional hook, nothing to release in memory
        """Release connections held by the bus."""


class MemoryBus(EventBus):
    """In-process fan-out, for a single server process."""

    def __init__(self, queue_size: int) -> None:
        super().__init__(queue_size)
        self._subscribers: dict[str, set[Subscription]] = {}

    async def publish(self, wall_id: str, message: str) -> None:
        for subscription in tuple(self._subscribers.get(wall_id, ())):
            subscription.offer(message)

    @asynccontextmanager
    async def subscribe(self, wall_id: str) -> AsyncIterator[Subscription]:
        subscription = Subscription(self.queue_size)
        subscribers = self._subscribers.setdefault(wall_id, set())
        subscribers.add(subscription)
        try:
            yield subscription
        finally:
            subscribers.discard(subscription)
            if not subscribers:
                self._subscribers.pop(wall_id, None)
