"""Several ``tagwall serve`` processes serve one wall (``TAGWALL_BUS=redis``).

Real processes on one database and one Redis, tiles speaking the websocket protocol to
either: every tile gets every change in version order whichever process took it, the
same frame everywhere, and a process killed with -9 loses no acknowledged change.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

from tests.conftest import TEST_SECRET, server_port
from webapp.cli.testing import ServerProcess, wait_until
from webapp.core.settings import CONTENT_DIR

# Several server processes each, one of them killed -9 mid-session: nothing beside them.
pytestmark = pytest.mark.alone

DEMO_TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]


class Tile:
    """A tile as the protocol sees it: the versions it was sent, one by one."""

    def __init__(self, socket: ClientConnection, tile_id: str, last_version: int | None) -> None:
        self.tile_id = tile_id
        self.socket = socket
        self.socket.send(json.dumps({"type": "hello", "last_version": last_version}))
        self.version = last_version
        self.frames: dict[int, str] = {}  # version -> the frame that brought it
        self.answers_ready = True  # False: the test says ready itself (a slow tile)

    def swap_of(self, version: int, timeout: float = 30) -> int:
        """Read on to the swap of the heavy change ``version``; its ``apply_at``."""
        while True:
            message = json.loads(str(self.socket.recv(timeout=timeout)))
            if message["type"] == "swap" and message["version"] == version:
                return int(message["apply_at"])

    def follow(self, until: int, timeout: float = 60) -> None:
        """Read until the tile is at version ``until``; each change must come next."""
        while self.version is None or self.version < until:
            raw = str(self.socket.recv(timeout=timeout))
            message: dict[str, Any] = json.loads(raw)
            kind = message["type"]
            if kind == "snapshot":
                self.version = message["version"]
            elif kind in ("event", "prepare"):
                assert self.version is not None, f"{self.tile_id}: a change before the snapshot"
                assert message["version"] == self.version + 1, (self.tile_id, raw)
                self.version = message["version"]
                self.frames[self.version] = raw
                if kind == "prepare" and self.answers_ready:
                    self.ready(self.version)

    def ready(self, version: int) -> None:
        self.socket.send(json.dumps({"type": "ready", "version": version}))


@pytest.fixture
def tiles() -> Iterator[Callable[..., Tile]]:
    """``tiles(server, tile_id, last_version=None)``: a tile connected to ``server``,
    closed at the end of the test."""
    with ExitStack() as sockets:

        def open_tile(server: ServerProcess, tile_id: str, last_version: int | None = None) -> Tile:
            url = server.tile_url("demo", tile_id, scheme="ws")
            return Tile(sockets.enter_context(connect(url)), tile_id, last_version)

        yield open_tile


def start(tmp_path: Path, name: str, database_url: str, redis: dict[str, str]) -> ServerProcess:
    server = ServerProcess(
        var_dir=tmp_path / name,
        database_url=database_url,
        secret=TEST_SECRET,
        port=server_port(),
        extra_env={
            "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
            "TAGWALL_APPLY_LEAD_MS": "100",
            "TAGWALL_SWAP_TIMEOUT_MS": "60000",  # a barrier that does not hear a tile shows
            **redis,
        },
    )
    server.start()
    return server


@pytest.fixture
def two_servers(
    tmp_path: Path, database_url: str, redis_server: str, redis_prefix: str
) -> Iterator[tuple[ServerProcess, ServerProcess]]:
    """Two server processes of one wall: one database, one Redis (the first starts
    alone, so the database is migrated once)."""
    redis = {"TAGWALL_BUS": "redis", "TAGWALL_REDIS_URL": redis_server}
    redis["TAGWALL_REDIS_PREFIX"] = redis_prefix
    first = start(tmp_path, "a", database_url, redis)
    second = start(tmp_path, "b", database_url, redis)
    yield first, second
    for server in (first, second):
        server.stop()


def change(server: ServerProcess, number: int) -> int:
    """A light change through ``server``; the version it was acknowledged as."""
    return server.change("demo", {"layers": {f"step-{number}": True}})


def test_tiles_on_either_process_get_every_change_in_order_and_in_step(
    two_servers: tuple[ServerProcess, ServerProcess], tiles: Callable[..., Tile]
) -> None:
    first, second = two_servers
    shown = [tiles(first if i < 3 else second, tile) for i, tile in enumerate(DEMO_TILES)]
    start_version = first.version("demo")
    for tile in shown:
        tile.follow(start_version)

    acknowledged = [change(first if n % 2 else second, n) for n in range(12)]

    assert acknowledged == list(range(start_version + 1, start_version + 13))
    for tile in shown:
        tile.follow(acknowledged[-1])
    for version in acknowledged:
        frames = {tile.frames[version] for tile in shown}
        assert len(frames) == 1, f"v{version}: every tile gets the same frame (one apply_at)"

    # A heavy change waits for every tile's ready, on either process, then swaps them all
    # at one instant: after the slowest tile (on the other process) said ready, and well
    # before the (long) swap timeout, which would mean a tile went unheard.
    slow = shown[-1]
    slow.answers_ready = False
    heavy = first.change("demo", {"app": "census"})
    for tile in shown:
        tile.follow(heavy)
    time.sleep(1.5)
    slow_ready_ms = time.time() * 1000
    slow.ready(heavy)
    swaps = {tile.swap_of(heavy, timeout=30) for tile in shown}
    assert len(swaps) == 1, "one swap instant for the tiles of both processes"
    assert swaps.pop() > slow_ready_ms, "the swap waited for the tile on the other process"


def test_a_process_killed_mid_session_loses_no_acknowledged_change(
    two_servers: tuple[ServerProcess, ServerProcess], tiles: Callable[..., Tile]
) -> None:
    """kill -9 of one process while both take changes: its tiles come back on the other
    with their last version, get what they missed, and every acknowledged change is
    in the wall's state."""
    doomed, survivor = two_servers
    on_doomed = [tiles(doomed, tile) for tile in DEMO_TILES[:3]]
    on_survivor = [tiles(survivor, tile) for tile in DEMO_TILES[3:]]
    acknowledged = [change(doomed if n % 2 else survivor, n) for n in range(6)]
    for tile in on_doomed + on_survivor:
        tile.follow(acknowledged[-1])

    before_kill = acknowledged[-1]
    assert doomed.process is not None
    os.kill(doomed.pid, signal.SIGKILL)
    doomed.process.wait(10)
    acknowledged += [change(survivor, n) for n in range(6, 10)]
    back = [tiles(survivor, tile.tile_id, tile.version) for tile in on_doomed]
    acknowledged.append(change(survivor, 10))

    for tile in back + on_survivor:
        tile.follow(acknowledged[-1])
    assert acknowledged == sorted(set(acknowledged)), "versions only go up, none twice"
    status = survivor.status("demo")
    assert status["version"] == acknowledged[-1] and "step-10" in status["state"]["layers"]
    for tile in back:  # ``follow`` took each version after the last one it showed, in turn
        assert set(range(before_kill + 1, acknowledged[-1] + 1)) <= set(tile.frames)


def workers(pid: int) -> list[int]:
    """uvicorn's worker processes under ``serve --workers`` (``pid``'s children that
    multiprocessing spawned to serve, not its resource tracker)."""
    found = []
    for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split():
        with contextlib.suppress(OSError):
            if b"spawn_main" in Path(f"/proc/{child}/cmdline").read_bytes():
                found.append(int(child))
    return found


@pytest.mark.postgres
def test_serve_with_two_workers_keeps_every_tile_in_order_when_a_worker_is_killed(
    tmp_path: Path,
    database_url: str,
    redis_server: str,
    redis_prefix: str,
    tiles: Callable[..., Tile],
) -> None:
    """``tagwall serve --workers 2``: tiles land on either worker; one worker killed
    with -9 is replaced, its tiles come back, and no acknowledged change is lost."""
    tagwall = Path(sys.executable).with_name("tagwall")
    server = ServerProcess(
        var_dir=tmp_path / "var",
        database_url=database_url,
        secret=TEST_SECRET,
        port=server_port(),
        command=[str(tagwall), "serve", "--workers", "2"],
        extra_env={
            "TAGWALL_WALL_CONFIGS": str(CONTENT_DIR / "walls"),
            "TAGWALL_BUS": "redis",
            "TAGWALL_REDIS_URL": redis_server,
            "TAGWALL_REDIS_PREFIX": redis_prefix,
        },
    )
    server.start()
    try:
        wait_until(lambda: len(workers(server.pid)) == 2, what="two workers")
        shown = [tiles(server, tile) for tile in DEMO_TILES * 2]
        acknowledged = [change(server, n) for n in range(6)]
        for tile in shown:
            tile.follow(acknowledged[-1])

        os.kill(workers(server.pid)[0], signal.SIGKILL)
        acknowledged += [change(server, n) for n in range(6, 12)]
        for index, tile in enumerate(shown):
            try:
                tile.follow(acknowledged[-1], timeout=10)
            except (ConnectionClosed, TimeoutError):  # its worker is gone: reconnect
                wait_until(server.healthy, what="a worker to answer")
                shown[index] = tiles(server, tile.tile_id, tile.version)
                shown[index].follow(acknowledged[-1])
        assert acknowledged == sorted(set(acknowledged))
        assert "step-11" in server.status("demo")["state"]["layers"]
        wait_until(lambda: len(workers(server.pid)) == 2, what="the killed worker replaced")
    finally:
        server.stop()
