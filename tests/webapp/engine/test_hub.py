import asyncio
import contextlib
import json
import threading
from collections.abc import AsyncIterator, Callable
from typing import Any

import pytest
from anyio import to_thread
from redis.exceptions import RedisError

from tests.cable import Cable
from tests.conftest import migrate
from webapp.database.connection import Database
from webapp.database.redis import connect_redis
from webapp.engine.bus.base import EventBus, Subscription
from webapp.engine.bus.memory import MemoryBus
from webapp.engine.bus.redis import RedisBus
from webapp.engine.hub import TileStatus, WallHub
from webapp.engine.protocol import Prepare
from webapp.engine.wall_state import StatePatch, View, now_ms, read_state

BOUND_S = 30  # what "soon" means on a loaded machine; the tests prove mechanisms, not speed


@pytest.fixture
async def hub(database_url: str) -> AsyncIterator[WallHub]:
    migrate(database_url)
    hub = WallHub(
        Database(database_url),
        MemoryBus(64),
        apply_lead_ms=100,
        swap_timeout_ms=300,
        keep_events=100,
    )
    await hub.watch(["demo"])
    yield hub
    await hub.close()
    hub.db.dispose()


async def soon(condition: Callable[[], bool]) -> None:
    async with asyncio.timeout(BOUND_S):
        while not condition():
            await asyncio.sleep(0.01)


async def connect(hub: WallHub, *tiles: str, wall: str = "demo") -> None:
    """Connect ``tiles`` to ``hub`` and wait until the hub has heard of them."""
    for tile in tiles:
        await hub.tile_connected(wall, tile, None)
    await soon(lambda: set(tiles) <= set(hub.connected_tiles(wall)))


def mode(value: str) -> StatePatch:
    return StatePatch(mode=value)


async def test_light_change_is_published_with_apply_time(hub: WallHub) -> None:
    async with hub.bus.subscribe("demo") as inbox:
        before = now_ms()
        change = await hub.commit("demo", mode("quiz").apply_to)
        message = json.loads(await inbox.next())
    assert change is not None
    assert message["type"] == "event" and message["version"] == 1
    assert message["changes"] == {"mode": "quiz"}
    assert message["apply_at"] >= before + 100


async def test_unchanged_state_publishes_nothing(hub: WallHub) -> None:
    await hub.commit("demo", mode("quiz").apply_to)
    async with hub.bus.subscribe("demo") as inbox:
        assert await hub.commit("demo", mode("quiz").apply_to) is None
        assert inbox.drain() == []


async def test_heavy_change_swaps_once_every_connected_tile_is_ready(hub: WallHub) -> None:
    await connect(hub, "r1c1", "r1c2")
    async with hub.bus.subscribe("demo") as inbox:
        await hub.commit("demo", StatePatch(view=View(zoom=2)).apply_to)
        prepare = json.loads(await inbox.next())
        assert prepare["type"] == "prepare" and prepare["version"] == 1
        await hub.tile_ready("demo", "r1c1", 1)
        await asyncio.sleep(0.05)
        assert inbox.drain() == []  # still waiting for r1c2
        started = now_ms()
        await hub.tile_ready("demo", "r1c2", 1)
        swap = json.loads(await asyncio.wait_for(inbox.next(), 1))
    assert swap["type"] == "swap" and swap["version"] == 1
    assert swap["apply_at"] >= started + 100
    assert now_ms() - started < 250  # did not wait for the timeout


async def test_heavy_change_swaps_after_timeout_without_a_silent_tile(hub: WallHub) -> None:
    await connect(hub, "r1c1")
    async with hub.bus.subscribe("demo") as inbox:
        started = now_ms()
        await hub.commit("demo", StatePatch(app="atlas").apply_to)
        assert json.loads(await inbox.next())["type"] == "prepare"
        swap = json.loads(await asyncio.wait_for(inbox.next(), 2))
    assert swap["type"] == "swap"
    assert now_ms() - started >= 300


async def test_the_instant_a_version_shows_is_its_swap_once_every_tile_prepared_it(
    hub: WallHub,
) -> None:
    """What a tour's dwell counts from: a heavy change shows at its swap, after the
    tiles' ready (the commit comes long before); a light one at its apply_at."""
    await connect(hub, "r1c1")
    async with hub.bus.subscribe("demo") as inbox:
        heavy = await hub.commit("demo", StatePatch(view=View(zoom=2)).apply_to)
        assert heavy is not None
        waiting = asyncio.ensure_future(hub.shown_at("demo", heavy.version))
        await inbox.next()  # prepare
        await asyncio.sleep(0.05)
        assert not waiting.done(), "not shown before the tile is ready"
        await hub.tile_ready("demo", "r1c1", heavy.version)
        swap = json.loads(await asyncio.wait_for(inbox.next(), BOUND_S))
        assert await asyncio.wait_for(waiting, BOUND_S) == swap["apply_at"]
        light = await hub.commit("demo", mode("quiz").apply_to)
        assert light is not None
        event = json.loads(await inbox.next())
    assert await hub.shown_at("demo", light.version) == event["apply_at"]
    assert await hub.shown_at("demo", heavy.version) == swap["apply_at"], "still known"


async def test_disconnecting_tile_releases_the_barrier(hub: WallHub) -> None:
    await connect(hub, "r1c1")
    async with hub.bus.subscribe("demo") as inbox:
        await hub.commit("demo", StatePatch(app="atlas").apply_to)
        await inbox.next()
        await hub.tile_disconnected("demo", "r1c1")
        swap = json.loads(await asyncio.wait_for(inbox.next(), 0.2))
    assert swap["type"] == "swap"


async def test_concurrent_changes_are_published_in_version_order(hub: WallHub) -> None:
    async def change(value: str) -> None:
        async with hub.placing("demo"):  # as the door holds the wall
            await hub.commit("demo", mode(value).apply_to)

    async with hub.bus.subscribe("demo") as inbox:
        await asyncio.gather(*(change(f"m{i}") for i in range(15)))
        versions = [json.loads(await inbox.next())["version"] for _ in range(15)]
    assert versions == list(range(1, 16))


async def test_a_change_does_not_queue_behind_a_full_shared_thread_pool(hub: WallHub) -> None:
    """A lecture hall's phones can hold every thread of the shared pool; the wall's
    change is committed and published on threads of its own meanwhile."""
    shared = to_thread.current_default_thread_limiter()
    release = threading.Event()
    threads = int(shared.total_tokens)
    blockers = [asyncio.ensure_future(to_thread.run_sync(release.wait)) for _ in range(threads)]
    try:
        await soon(lambda: shared.available_tokens == 0)
        async with hub.bus.subscribe("demo") as inbox:
            async with asyncio.timeout(BOUND_S):
                change = await hub.commit("demo", mode("quiz").apply_to)
                message = json.loads(await inbox.next())
        assert change is not None and message["version"] == change.version
    finally:
        release.set()
        await asyncio.gather(*blockers)


async def test_tile_status_tracks_connections_and_reports(hub: WallHub) -> None:
    await hub.tile_connected("demo", "r1c1", "10.0.0.5")
    await hub.tile_connected("demo", "r1c1", "10.0.0.5")
    await hub.tile_applied("demo", "r1c1", 3, 100.0, ["shows the flat map: no WebGL"])

    def status() -> TileStatus:
        return hub.tile_statuses("demo").get("r1c1") or TileStatus(tile_id="r1c1")

    await soon(lambda: status().version == 3)
    assert status().notes == ["shows the flat map: no WebGL"]
    await hub.tile_applied("demo", "r1c1", 4, 123.0)  # shows what was asked again
    await hub.tile_disconnected("demo", "r1c1")
    await soon(lambda: status().version == 4 and status().connections == 1)
    assert status().address == "10.0.0.5" and status().notes == []
    await hub.tile_disconnected("demo", "r1c1")
    await soon(lambda: hub.connected_tiles("demo") == [])


async def test_a_change_the_bus_cannot_publish_stays_committed(
    database_url: str, redis_cable: Cable, redis_prefix: str, caplog: pytest.LogCaptureFixture
) -> None:
    """Redis gone between holding the wall and publishing: the change is made (the
    database is the truth) and said so in the log; tiles catch up by the version gap."""
    migrate(database_url)
    bus = RedisBus(connect_redis(redis_cable.url), redis_prefix, queue_size=8, max_len=100)
    hub = WallHub(
        Database(database_url), bus, apply_lead_ms=0, swap_timeout_ms=300, keep_events=100
    )
    try:
        async with hub.placing("demo"):
            redis_cable.cut()
            change = await hub.commit("demo", mode("quiz").apply_to)
        assert change is not None and read_state(hub.db, "demo")[0] == change.version
        assert "demo v1 committed but not published" in caplog.text
    finally:
        await hub.close()
        with contextlib.suppress(RedisError, OSError):
            await bus.redis.aclose()
        hub.db.dispose()


# --- several processes: tile presence and the barrier through the bus's tiles channel ---


@pytest.fixture(params=["memory", "redis"])
async def make_hub(request: pytest.FixtureRequest, database_url: str) -> AsyncIterator[Any]:
    """Hubs on one database, watching wall "demo": on Redis each with a client of its own
    (a process each); in memory all on one bus (one process, the same code path)."""
    migrate(database_url)
    made: list[WallHub] = []
    shared = MemoryBus(64)

    async def make(**options: float) -> WallHub:
        bus: EventBus = shared
        if request.param == "redis":
            url = request.getfixturevalue("redis_server")
            prefix = request.getfixturevalue("redis_prefix")
            bus = RedisBus(connect_redis(url), prefix, queue_size=64, max_len=100)
        settings: dict[str, Any] = {
            "apply_lead_ms": 0,
            "swap_timeout_ms": 60_000,
            "keep_events": 100,
            **options,
        }
        hub = WallHub(Database(database_url), bus, **settings)
        await hub.watch(["demo"])
        made.append(hub)
        return hub

    yield make
    for hub in made:
        await hub.close()
        if isinstance(hub.bus, RedisBus):
            with contextlib.suppress(RedisError, OSError):
                await hub.bus.redis.aclose()
        hub.db.dispose()


async def next_frame(inbox: Subscription) -> dict[str, Any]:
    async with asyncio.timeout(BOUND_S):
        frame: dict[str, Any] = json.loads(await inbox.next())
        return frame


async def test_a_tile_of_another_process_is_known_to_this_one(make_hub: Any) -> None:
    first, second = await make_hub(), await make_hub()
    await second.tile_connected("demo", "r1c1", "10.0.0.7")
    await second.tile_applied("demo", "r1c1", 3, 42.0)
    await soon(lambda: first.connected_tiles("demo") == ["r1c1"])
    await soon(lambda: first.tile_statuses("demo")["r1c1"].version == 3)
    status = first.tile_statuses("demo")["r1c1"]
    assert status.connections == 1 and status.address == "10.0.0.7"
    await first.tile_connected("demo", "r1c1", "10.0.0.8")  # the same tile on both
    await soon(lambda: second.tile_statuses("demo")["r1c1"].connections == 2)
    await second.tile_disconnected("demo", "r1c1")
    await soon(lambda: first.tile_statuses("demo")["r1c1"].connections == 1)


async def test_a_heavy_change_waits_for_the_ready_of_a_tile_on_another_process(
    make_hub: Any,
) -> None:
    """The swap timeout is a minute: a swap within the bound came from the barrier."""
    committing, other = await make_hub(), await make_hub()
    await committing.tile_connected("demo", "r1c1", None)
    await other.tile_connected("demo", "r1c2", None)
    await soon(lambda: committing.connected_tiles("demo") == ["r1c1", "r1c2"])
    async with committing.bus.subscribe("demo") as inbox:
        await committing.commit("demo", StatePatch(app="atlas").apply_to)
        prepare = await next_frame(inbox)
        assert prepare["type"] == "prepare"
        await committing.tile_ready("demo", "r1c1", prepare["version"])
        await asyncio.sleep(0.3)
        assert inbox.drain() == [], "swapped without the other process's tile"
        await other.tile_ready("demo", "r1c2", prepare["version"])
        swap = await next_frame(inbox)
    assert swap == {**swap, "type": "swap", "version": prepare["version"]}


async def test_a_process_that_falls_silent_loses_its_tiles_and_releases_barriers(
    make_hub: Any,
) -> None:
    """A killed process says nothing more: after three heartbeats its tiles are gone
    from the view, and a change waiting for them swaps (not after the minute)."""
    committing = await make_hub(heartbeat_s=0.2)
    doomed = await make_hub(heartbeat_s=0.2)
    await doomed.tile_connected("demo", "r1c2", None)
    await soon(lambda: committing.connected_tiles("demo") == ["r1c2"])
    async with committing.bus.subscribe("demo") as inbox:
        await committing.commit("demo", StatePatch(app="atlas").apply_to)
        assert (await next_frame(inbox))["type"] == "prepare"
        for task in tuple(doomed._tasks):  # killed: no disconnect, no heartbeat
            task.cancel()
        assert (await next_frame(inbox))["type"] == "swap"
    assert committing.connected_tiles("demo") == []
    assert "r1c2" not in committing.tile_statuses("demo")


async def test_a_prepared_change_without_its_swap_is_swapped_by_another_process(
    make_hub: Any,
) -> None:
    """The committing process died between prepare and swap: another swaps it after
    the swap timeout and the grace, so tiles are not left waiting."""
    survivor = await make_hub(swap_timeout_ms=100, orphan_grace_s=0.1)
    async with survivor.bus.subscribe("demo") as inbox:
        await survivor.bus.publish("demo", Prepare(version=7, changes={}).model_dump_json())
        assert (await next_frame(inbox))["type"] == "prepare"
        swap = await next_frame(inbox)
    assert swap["type"] == "swap" and swap["version"] == 7


async def test_a_swapped_change_is_not_swapped_again(make_hub: Any) -> None:
    hub = await make_hub(swap_timeout_ms=100, orphan_grace_s=0.1)
    async with hub.bus.subscribe("demo") as inbox:
        await hub.commit("demo", StatePatch(app="atlas").apply_to)
        assert [(await next_frame(inbox))["type"] for _ in range(2)] == ["prepare", "swap"]
        await asyncio.sleep(0.5)
        assert inbox.drain() == []
