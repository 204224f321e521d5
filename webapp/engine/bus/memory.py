"""The bus of one server process: fan-out in memory, a lock per wall."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from webapp.engine.bus.base import (
    EVENTS,
    EventBus,
    Subscription,
)


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
