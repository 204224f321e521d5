"""Which tiles are connected to any process serving a wall, and what they last reported.

A tile talks to one process; every process needs to know all of a wall's tiles (the
dashboard lists them, a heavy change waits for each one's ``ready``). Each hub tells the
others about its own tiles on the wall's ``tiles`` channel of the bus (:class:`TilesHeard`)
and hears every process's reports, its own included, into one :class:`Presence`. A
process re-announces all its tiles every heartbeat; one not heard from for a few
heartbeats (killed) is dropped with its tiles.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from pydantic import BaseModel

TILES = "tiles"
"""The bus channel of tile reports (see :mod:`webapp.engine.bus`)."""


class TileStatus(BaseModel):
    """What is known of one tile's connection(s); shown on the dashboard."""

    tile_id: str
    connections: int = 0
    connected_since: int | None = None
    last_seen: int | None = None
    version: int | None = None
    applied_at: float | None = None
    address: str | None = None
    notes: list[str] = []  # what it shows otherwise than asked, as of its last applied


class TilesHeard(BaseModel):
    """Between processes, on a wall's ``tiles`` channel: how ``process``'s tiles stand.

    A report carries whole statuses, so a repeated or late one does no harm beyond the
    next report: the tiles that changed (connected, disconnected, ready, applied), or,
    as a heartbeat, every tile of the process (``every``).
    """

    process: str
    tiles: list[TileStatus]
    every: bool = False
    ready: int | None = None  # the tiles prepared this version (a heavy change's barrier)


@dataclass
class _Process:
    heard_at: float  # time.monotonic()
    tiles: dict[str, TileStatus] = field(default_factory=dict)


class Presence:
    """Every process's tiles of every wall, as last heard; a process not heard from for
    ``expiry_s`` is gone, with its tiles."""

    def __init__(self, expiry_s: float) -> None:
        self.expiry_s = expiry_s
        self._walls: dict[str, dict[str, _Process]] = {}

    def hear(self, wall_id: str, report: TilesHeard) -> None:
        processes = self._walls.setdefault(wall_id, {})
        process = processes.setdefault(report.process, _Process(time.monotonic()))
        process.heard_at = time.monotonic()
        if report.every:
            process.tiles = {}
        process.tiles.update((status.tile_id, status) for status in report.tiles)

    def _live(self, wall_id: str) -> list[_Process]:
        processes = self._walls.get(wall_id, {})
        now = time.monotonic()
        for name, process in tuple(processes.items()):
            if now - process.heard_at > self.expiry_s:
                del processes[name]
        return list(processes.values())

    def statuses(self, wall_id: str) -> dict[str, TileStatus]:
        """Each tile's status over every live process: its connections added up, the
        rest from the process that heard from it last."""
        merged: dict[str, TileStatus] = {}
        for process in self._live(wall_id):
            for status in process.tiles.values():
                known = merged.get(status.tile_id)
                if known is None:
                    merged[status.tile_id] = status.model_copy()
                    continue
                latest = status if (status.last_seen or 0) > (known.last_seen or 0) else known
                since = [s for s in (known.connected_since, status.connected_since) if s]
                merged[status.tile_id] = latest.model_copy(
                    update={
                        "connections": known.connections + status.connections,
                        "connected_since": min(since) if since else None,
                    }
                )
        return merged

    def connected(self, wall_id: str) -> set[str]:
        return {tile for tile, status in self.statuses(wall_id).items() if status.connections}
