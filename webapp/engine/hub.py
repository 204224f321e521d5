"""The wall hub: commits state changes, publishes them in order, keeps tiles in step.

One hub per app (in ``app.state``), never a module global. It also knows which
tiles are connected to this process, which the prepare -> ready -> swap barrier
needs: a heavy change is swapped once every connected tile is ready, or when the
timeout passes, whichever comes first (the web form of the MPI barrier before the
buffer swap).
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Coroutine
from contextlib import AbstractAsyncContextManager
from dataclasses import dataclass, field
from typing import Any

from anyio import to_thread

from webapp.database.connection import Database
from webapp.engine.bus import BusUnavailable, EventBus
from webapp.engine.protocol import Event, Prepare, Swap
from webapp.engine.wall_state import Change, WallState, commit_change, now_ms

log = logging.getLogger(__name__)


@dataclass
class TileStatus:
    """What the hub knows of one tile's connection(s); shown on the dashboard."""

    tile_id: str
    connections: int = 0
    connected_since: int | None = None
    last_seen: int | None = None
    version: int | None = None
    applied_at: float | None = None
    address: str | None = None


@dataclass
class _Barrier:
    waiting: set[str]
    done: asyncio.Event = field(default_factory=asyncio.Event)

    def discard(self, tile_id: str) -> None:
        self.waiting.discard(tile_id)
        if not self.waiting:
            self.done.set()


class WallHub:
    """Commits, publishes and synchronises changes for every wall of this server."""

    def __init__(
        self,
        db: Database,
        bus: EventBus,
        *,
        apply_lead_ms: int,
        swap_timeout_ms: int,
        keep_events: int,
    ) -> None:
        self.db = db
        self.bus = bus
        self.apply_lead_ms = apply_lead_ms
        self.swap_timeout_ms = swap_timeout_ms
        self.keep_events = keep_events
        self._tiles: dict[str, dict[str, TileStatus]] = {}
        self._barriers: dict[tuple[str, int], _Barrier] = {}
        self._tasks: set[asyncio.Task[None]] = set()

    def placing(self, wall_id: str) -> AbstractAsyncContextManager[None]:
        """Held by the door (``webapp.engine.changes``) through a whole change, placing its
        codes included, so two changes of one wall never interleave (a layout always
        matches its view) and publication order is version order. The bus holds the
        wall: within this process, and across every process sharing the bus."""
        return self.bus.wall_lock(wall_id)

    async def commit(self, wall_id: str, update: Callable[[WallState], WallState]) -> Change | None:
        """Bump the version, persist, then publish.

        Only the door (``webapp.engine.changes``) calls this, holding
        :meth:`placing`: that hold, not a lock of the hub's, makes publication order
        equal commit order, in every process of the wall.
        """
        change = await to_thread.run_sync(
            lambda: commit_change(self.db, wall_id, update, keep_events=self.keep_events)
        )
        if change is None:
            return None
        if change.heavy:
            barrier = _Barrier(set(self.connected_tiles(wall_id)))
            self._barriers[(wall_id, change.version)] = barrier
            prepare = Prepare(version=change.version, changes=change.changes)
            await self._publish(wall_id, change.version, prepare.model_dump_json())
            self._spawn(self._swap_when_ready(wall_id, change.version, barrier))
        else:
            event = Event(
                version=change.version,
                changes=change.changes,
                apply_at=now_ms() + self.apply_lead_ms,
            )
            await self._publish(wall_id, change.version, event.model_dump_json())
        return change

    async def _publish(self, wall_id: str, version: int, frame: str) -> None:
        """Publish ``frame``; a bus that fails now does not undo the committed change.
        Tiles that miss the frame see the gap in the next one and catch up with
        ``hello`` from the database."""
        try:
            await self.bus.publish(wall_id, frame)
        except BusUnavailable as error:
            log.warning("wall %s v%d committed but not published: %s", wall_id, version, error)

    async def _swap_when_ready(self, wall_id: str, version: int, barrier: _Barrier) -> None:
        if barrier.waiting:
            try:
                await asyncio.wait_for(barrier.done.wait(), self.swap_timeout_ms / 1000)
            except TimeoutError:
                log.warning(
                    "wall %s v%d: swapping without %s (not ready in time)",
                    wall_id,
                    version,
                    ", ".join(sorted(barrier.waiting)),
                )
        self._barriers.pop((wall_id, version), None)
        swap = Swap(version=version, apply_at=now_ms() + self.apply_lead_ms)
        await self._publish(wall_id, version, swap.model_dump_json())

    def _spawn(self, coroutine: Coroutine[Any, Any, None]) -> None:
        task = asyncio.ensure_future(coroutine)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # --- tiles ------------------------------------------------------------------

    def tile_connected(self, wall_id: str, tile_id: str, address: str | None) -> None:
        status = self._tiles.setdefault(wall_id, {}).setdefault(tile_id, TileStatus(tile_id))
        status.connections += 1
        status.connected_since = status.connected_since or now_ms()
        status.last_seen = now_ms()
        status.address = address

    def tile_disconnected(self, wall_id: str, tile_id: str) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is None:
            return
        status.connections = max(0, status.connections - 1)
        status.last_seen = now_ms()
        if status.connections == 0:
            status.connected_since = None
            for (barrier_wall, _), barrier in tuple(self._barriers.items()):
                if barrier_wall == wall_id:
                    barrier.discard(tile_id)

    def tile_seen(self, wall_id: str, tile_id: str) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is not None:
            status.last_seen = now_ms()

    def tile_ready(self, wall_id: str, tile_id: str, version: int) -> None:
        self.tile_seen(wall_id, tile_id)
        barrier = self._barriers.get((wall_id, version))
        if barrier is not None:
            barrier.discard(tile_id)

    def tile_applied(self, wall_id: str, tile_id: str, version: int, server_time: float) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is not None:
            status.version = version
            status.applied_at = server_time
            status.last_seen = now_ms()

    def connected_tiles(self, wall_id: str) -> list[str]:
        return [t.tile_id for t in self._tiles.get(wall_id, {}).values() if t.connections]

    def tile_statuses(self, wall_id: str) -> dict[str, TileStatus]:
        return dict(self._tiles.get(wall_id, {}))

    async def close(self) -> None:
        for task in tuple(self._tasks):
            task.cancel()
        await self.bus.close()
