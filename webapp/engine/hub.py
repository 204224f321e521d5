"""The wall hub: commits state changes, publishes them in order, keeps tiles in step.

One hub per app (in ``app.state``), never a module global. It knows which tiles are
connected to any process serving its walls (:mod:`webapp.engine.presence`: each hub
reports its own tiles on the wall's ``tiles`` channel and hears every process's), which
the prepare -> ready -> swap barrier needs: a heavy change is swapped once every tile
connected anywhere is ready, or when the timeout passes, whichever comes first (the web
form of the MPI barrier before the buffer swap). The ``ready`` of a tile, on whichever
process, reaches the committing hub through the channel, its own tiles' too: one path
for one process and for many. Every hub also watches the ``prepare`` frames: should the
committing process die before its ``swap``, another publishes it (tiles take the first
swap of a version and ignore the rest).
"""

from __future__ import annotations

import asyncio
import json
import logging
import uuid
from collections.abc import Callable, Iterable, Sequence
from contextlib import AbstractAsyncContextManager
from dataclasses import dataclass, field
from typing import Any, TypeVar

from anyio import CapacityLimiter

from webapp.core.tasks import cancel_and_wait
from webapp.core.threads import run_blocking_within
from webapp.database.connection import Database
from webapp.engine.bus.base import EVENTS, BusUnavailable, EventBus, follow
from webapp.engine.presence import TILES, Presence, TilesHeard, TileStatus
from webapp.engine.protocol import Event, Prepare, Swap
from webapp.engine.wall_state import (
    CORE_HEAVY_KEYS,
    Change,
    WallState,
    commit_change,
    now_ms,
)

__all__ = ["TileStatus", "WallHub"]

HEARTBEAT_S = 2.0
"""How often a hub re-announces its tiles; a process silent for three heartbeats is gone."""
ORPHAN_GRACE_S = 2.0
"""How long past the swap timeout a prepared change waits for its swap before any process
publishes it (its committing process died)."""
SHOWN_KEPT = 64
"""Versions per wall whose instant on the tiles a hub remembers (see :meth:`WallHub.shown_at`)."""
WALL_THREADS = 8
"""Worker threads of the walls' own: changes and tiles' catch-ups (see :meth:`WallHub.run_sync`)."""

T = TypeVar("T")

log = logging.getLogger(__name__)


@dataclass
class _Barrier:
    waiting: set[str]
    done: asyncio.Event = field(default_factory=asyncio.Event)

    def discard(self, tile_id: str) -> None:
        self.waiting.discard(tile_id)
        if not self.waiting:
            self.done.set()

    def keep_only(self, tiles: set[str]) -> None:
        """Stop waiting for tiles no longer connected anywhere."""
        for tile_id in self.waiting - tiles:
            self.discard(tile_id)


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
        heavy_keys: frozenset[str] = CORE_HEAVY_KEYS,
        heartbeat_s: float = HEARTBEAT_S,
        orphan_grace_s: float = ORPHAN_GRACE_S,
    ) -> None:
        self.db = db
        self.bus = bus
        self.apply_lead_ms = apply_lead_ms
        self.swap_timeout_ms = swap_timeout_ms
        self.keep_events = keep_events
        self.heavy_keys = heavy_keys  # the core's and every installed app's
        self.heartbeat_s = heartbeat_s
        self.orphan_grace_s = orphan_grace_s
        self.process_id = uuid.uuid4().hex  # this process, in its tile reports
        self.presence = Presence(expiry_s=3 * heartbeat_s)
        self._tiles: dict[str, dict[str, TileStatus]] = {}  # this process's own tiles
        self._barriers: dict[tuple[str, int], _Barrier] = {}
        self._orphans: dict[tuple[str, int], asyncio.Task[None]] = {}  # prepared, not swapped
        self._shown: dict[str, dict[int, int]] = {}  # wall -> version -> apply_at, the latest
        self._shown_waiting: dict[tuple[str, int], asyncio.Future[int]] = {}
        self._tasks: set[asyncio.Task[None]] = set()
        self._threads: CapacityLimiter | None = None  # made in the event loop, on first use

    async def run_sync(self, function: Callable[..., T], *args: Any) -> T:
        """Run ``function`` in a worker thread of the walls' own. A lecture hall's phones
        fill the shared pool with page requests; a wall's change and its tiles'
        catch-up never queue behind them."""
        if self._threads is None:
            self._threads = CapacityLimiter(WALL_THREADS)
        return await run_blocking_within(self._threads, function, *args)

    async def watch(self, wall_ids: Iterable[str]) -> None:
        """Follow the walls' tile reports and prepared changes, and announce this
        process's tiles every heartbeat, until :meth:`close` (the app's lifespan);
        returns once the channels are subscribed to."""
        opened = []
        for wall_id in wall_ids:
            for channel, handle in (
                (TILES, self._hear_tiles),
                (EVENTS, self._hear_event),
            ):
                opened.append(asyncio.Event())
                self._spawn(follow(self.bus, wall_id, channel, _bound(handle, wall_id), opened[-1]))
            self._spawn(self._heartbeat(wall_id))
        for event in opened:
            await event.wait()

    def placing(self, wall_id: str) -> AbstractAsyncContextManager[None]:
        """Held by the door (``webapp.changes.door``) through a whole change, placing its
        codes included, so two changes of one wall never interleave (a layout always
        matches its view) and publication order is version order. The bus holds the
        wall: within this process, and across every process sharing the bus."""
        return self.bus.wall_lock(wall_id)

    async def commit(self, wall_id: str, update: Callable[[WallState], WallState]) -> Change | None:
        """Bump the version, persist, then publish.

        Only the door (``webapp.changes.door``) calls this, holding
        :meth:`placing`: that hold, not a lock of the hub's, makes publication order
        equal commit order, in every process of the wall.
        """
        change = await self.run_sync(
            lambda: commit_change(
                self.db, wall_id, update, keep_events=self.keep_events, heavy_keys=self.heavy_keys
            )
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
        await self._swap(wall_id, version)

    async def _swap(self, wall_id: str, version: int) -> None:
        swap = Swap(version=version, apply_at=now_ms() + self.apply_lead_ms)
        await self._publish(wall_id, version, swap.model_dump_json())

    def _hear_event(self, wall_id: str, frame: str) -> None:
        """Track prepared changes until their swap (see :meth:`_swap_orphan`), and the
        instant each version shows (see :meth:`shown_at`)."""
        message = json.loads(frame)
        key = (wall_id, message.get("version"))
        if message.get("type") == "prepare" and key not in self._orphans:
            self._orphans[key] = self._spawn(self._swap_orphan(wall_id, message["version"]))
        elif message.get("type") == "swap" and (watcher := self._orphans.pop(key, None)):
            watcher.cancel()
        if message.get("type") in ("event", "swap"):
            self._heard_shown(wall_id, int(message["version"]), int(message["apply_at"]))

    def _heard_shown(self, wall_id: str, version: int, apply_at: int) -> None:
        """Tiles take the first swap of a version: its instant is the one kept."""
        shown = self._shown.setdefault(wall_id, {})
        if version in shown:
            return
        shown[version] = apply_at
        while len(shown) > SHOWN_KEPT:
            del shown[next(iter(shown))]
        if (waiting := self._shown_waiting.pop((wall_id, version), None)) and not waiting.done():
            waiting.set_result(apply_at)

    async def shown_at(self, wall_id: str, version: int) -> int | None:
        """The wall clock's instant (server ms) from which every tile shows ``version``
        of the wall: a light change's ``apply_at``, a heavy one's swap's, which comes
        once every tile has prepared it. Waits for it as long as a swap may take (the
        swap timeout, and an orphan's grace); None when it was not heard by then (a bus
        that lost it)."""
        if (kept := self._shown.get(wall_id, {}).get(version)) is not None:
            return kept
        key = (wall_id, version)
        waiting = self._shown_waiting.get(key)
        if waiting is None:
            waiting = self._shown_waiting[key] = asyncio.get_running_loop().create_future()
        try:
            return await asyncio.wait_for(
                asyncio.shield(waiting), self.swap_timeout_ms / 1000 + 2 * self.orphan_grace_s
            )
        except TimeoutError:
            if self._shown_waiting.get(key) is waiting:
                del self._shown_waiting[key]
            return None

    async def _swap_orphan(self, wall_id: str, version: int) -> None:
        """A prepared change with no swap long after the swap timeout lost its committing
        process: swap it here, so its tiles do not wait forever. Several processes may;
        tiles take the first swap of a version and ignore the others."""
        await asyncio.sleep(self.swap_timeout_ms / 1000 + self.orphan_grace_s)
        self._orphans.pop((wall_id, version), None)
        log.warning("wall %s v%d: prepared but never swapped; swapping it", wall_id, version)
        await self._swap(wall_id, version)

    def _spawn(self, coroutine: Any) -> asyncio.Task[None]:
        task: asyncio.Task[None] = asyncio.ensure_future(coroutine)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    # --- tiles ------------------------------------------------------------------
    # This process's own tiles are kept here and reported on the wall's tiles channel;
    # what every process reported is heard into ``presence``, which the rest reads.

    async def tile_connected(self, wall_id: str, tile_id: str, address: str | None) -> None:
        status = self._tiles.setdefault(wall_id, {}).setdefault(
            tile_id, TileStatus(tile_id=tile_id)
        )
        status.connections += 1
        status.connected_since = status.connected_since or now_ms()
        status.last_seen = now_ms()
        status.address = address
        await self._report(wall_id, [status])

    async def tile_disconnected(self, wall_id: str, tile_id: str) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is None:
            return
        status.connections = max(0, status.connections - 1)
        status.last_seen = now_ms()
        if status.connections == 0:
            status.connected_since = None
        await self._report(wall_id, [status])

    async def tile_ready(self, wall_id: str, tile_id: str, version: int) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is not None:
            status.last_seen = now_ms()
            await self._report(wall_id, [status], ready=version)

    async def tile_applied(
        self,
        wall_id: str,
        tile_id: str,
        version: int,
        server_time: float,
        notes: Sequence[str] = (),
    ) -> None:
        status = self._tiles.get(wall_id, {}).get(tile_id)
        if status is not None:
            status.version = version
            status.applied_at = server_time
            status.notes = list(notes)
            status.last_seen = now_ms()
            await self._report(wall_id, [status])

    async def _report(
        self,
        wall_id: str,
        tiles: list[TileStatus],
        *,
        every: bool = False,
        ready: int | None = None,
    ) -> None:
        """Tell every process (this one too) how this process's ``tiles`` stand; a bus
        that does not answer loses the report until the next heartbeat."""
        report = TilesHeard(process=self.process_id, tiles=tiles, every=every, ready=ready)
        try:
            await self.bus.publish(wall_id, report.model_dump_json(), TILES)
        except BusUnavailable as error:
            log.warning("wall %s: could not report tiles: %s", wall_id, error)

    def _hear_tiles(self, wall_id: str, frame: str) -> None:
        report = TilesHeard.model_validate_json(frame)
        self.presence.hear(wall_id, report)
        if report.ready is not None and (barrier := self._barriers.get((wall_id, report.ready))):
            for status in report.tiles:
                barrier.discard(status.tile_id)
        self._settle(wall_id)

    def _settle(self, wall_id: str) -> None:
        """Barriers stop waiting for tiles no longer connected anywhere."""
        barriers = [b for (wall, _), b in self._barriers.items() if wall == wall_id]
        if barriers:
            connected = self.presence.connected(wall_id)
            for barrier in barriers:
                barrier.keep_only(connected)

    async def _heartbeat(self, wall_id: str) -> None:
        """Announce every tile of this process now and then, so the others keep it (and
        learn of it after a report they missed); settle barriers as processes go."""
        while True:
            if tiles := list(self._tiles.get(wall_id, {}).values()):
                await self._report(wall_id, tiles, every=True)
            self._settle(wall_id)
            await asyncio.sleep(self.heartbeat_s)

    def connected_tiles(self, wall_id: str) -> list[str]:
        """The tiles connected to any live process serving ``wall_id``."""
        return sorted(self.presence.connected(wall_id))

    def tile_statuses(self, wall_id: str) -> dict[str, TileStatus]:
        """What every live process knows of ``wall_id``'s tiles."""
        return self.presence.statuses(wall_id)

    async def close(self) -> None:
        await cancel_and_wait(*self._tasks)
        await self.bus.close()


def _bound(handle: Callable[[str, str], None], wall_id: str) -> Callable[[str], None]:
    return lambda frame: handle(wall_id, frame)
