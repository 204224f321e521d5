"""A cache each process keeps of what any process may change, dropped everywhere at once.

The process that changes the cached thing calls :meth:`Forgetting.forget`: its own
cache is dropped and the others are told on the bus (a channel of no wall in
particular); every process that :meth:`~Forgetting.follow` s the channel drops its own
on hearing it. A cache that uses this keeps a short lifetime too: the bound on how
stale it is when the word is lost (a bus outage). The scan path's codes
(``webapp.tags.scanning.CodeDirectory``) and the address rules
(``webapp.people.addresses.AddressRules``) are kept this way.
"""

from __future__ import annotations

import asyncio
import logging
import uuid
from collections.abc import Callable

from pydantic import BaseModel

from webapp.core.tasks import cancel_and_wait
from webapp.engine.bus.base import BusUnavailable, EventBus, follow

log = logging.getLogger(__name__)

EVERY_WALL = "*"
"""The word is said on a channel of no wall in particular."""


class Changed(BaseModel):
    """Between processes: ``process`` changed what the channel's caches hold."""

    process: str


class Forgetting:
    """Drops a process's cache (``drop``) here and, through ``bus``, in every process
    that follows ``channel``."""

    def __init__(self, bus: EventBus | None, channel: str, drop: Callable[[], None]) -> None:
        self.bus = bus
        self.channel = channel
        self.drop = drop
        self.process = uuid.uuid4().hex
        self._loop: asyncio.AbstractEventLoop | None = None  # set while following
        self._telling: set[asyncio.Task[None]] = set()

    def forget(self) -> None:
        """Drop the cache here and tell the other processes (callable from a worker
        thread too), while :meth:`follow` runs."""
        self.drop()
        if self._loop is not None:
            self._loop.call_soon_threadsafe(self._tell_others)

    async def follow(self, opened: asyncio.Event | None = None) -> None:
        """Hear the other processes' :meth:`forget` until cancelled (the app's lifespan)."""
        if self.bus is None:
            return
        self._loop = asyncio.get_running_loop()
        try:
            await follow(self.bus, EVERY_WALL, self.channel, self._heard, opened)
        finally:
            self._loop = None
            await cancel_and_wait(*self._telling)

    def _heard(self, frame: str) -> None:
        if Changed.model_validate_json(frame).process != self.process:
            self.drop()

    def _tell_others(self) -> None:
        task = asyncio.ensure_future(self._publish())
        self._telling.add(task)
        task.add_done_callback(self._telling.discard)

    async def _publish(self) -> None:
        if self.bus is None:
            return
        try:
            await self.bus.publish(
                EVERY_WALL, Changed(process=self.process).model_dump_json(), self.channel
            )
        except BusUnavailable as error:
            log.warning("could not tell the other processes (%s): %s", self.channel, error)
