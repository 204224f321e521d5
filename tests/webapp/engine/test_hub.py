import asyncio
import contextlib
import json

import pytest
from redis.exceptions import RedisError

from tests.conftest import RedisCable
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.database.redis import connect_redis
from webapp.engine.bus import MemoryBus, RedisBus
from webapp.engine.hub import WallHub
from webapp.engine.wall_state import StatePatch, View, now_ms, read_state


@pytest.fixture
def hub(database_url: str) -> WallHub:
    upgrade(database_url)
    return WallHub(
        Database(database_url),
        MemoryBus(64),
        apply_lead_ms=100,
        swap_timeout_ms=300,
        keep_events=100,
    )


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
    hub.tile_connected("demo", "r1c1", None)
    hub.tile_connected("demo", "r1c2", None)
    async with hub.bus.subscribe("demo") as inbox:
        await hub.commit("demo", StatePatch(view=View(zoom=2)).apply_to)
        prepare = json.loads(await inbox.next())
        assert prepare["type"] == "prepare" and prepare["version"] == 1
        hub.tile_ready("demo", "r1c1", 1)
        await asyncio.sleep(0.05)
        assert inbox.drain() == []  # still waiting for r1c2
        started = now_ms()
        hub.tile_ready("demo", "r1c2", 1)
        swap = json.loads(await asyncio.wait_for(inbox.next(), 1))
    assert swap["type"] == "swap" and swap["version"] == 1
    assert swap["apply_at"] >= started + 100
    assert now_ms() - started < 250  # did not wait for the timeout


async def test_heavy_change_swaps_after_timeout_without_a_silent_tile(hub: WallHub) -> None:
    hub.tile_connected("demo", "r1c1", None)
    async with hub.bus.subscribe("demo") as inbox:
        started = now_ms()
        await hub.commit("demo", StatePatch(app="atlas").apply_to)
        assert json.loads(await inbox.next())["type"] == "prepare"
        swap = json.loads(await asyncio.wait_for(inbox.next(), 2))
    assert swap["type"] == "swap"
    assert now_ms() - started >= 300


async def test_disconnecting_tile_releases_the_barrier(hub: WallHub) -> None:
    hub.tile_connected("demo", "r1c1", None)
    async with hub.bus.subscribe("demo") as inbox:
        await hub.commit("demo", StatePatch(app="atlas").apply_to)
        await inbox.next()
        hub.tile_disconnected("demo", "r1c1")
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


async def test_tile_status_tracks_connections_and_reports(hub: WallHub) -> None:
    hub.tile_connected("demo", "r1c1", "10.0.0.5")
    hub.tile_connected("demo", "r1c1", "10.0.0.5")
    hub.tile_applied("demo", "r1c1", 4, 123.0)
    hub.tile_disconnected("demo", "r1c1")
    status = hub.tile_statuses("demo")["r1c1"]
    assert status.connections == 1 and status.version == 4 and status.address == "10.0.0.5"
    hub.tile_disconnected("demo", "r1c1")
    assert hub.connected_tiles("demo") == []


async def test_a_change_the_bus_cannot_publish_stays_committed(
    database_url: str, redis_cable: RedisCable, redis_prefix: str, caplog: pytest.LogCaptureFixture
) -> None:
    """Redis gone between holding the wall and publishing: the change is made (the
    database is the truth) and said so in the log; tiles catch up by the version gap."""
    upgrade(database_url)
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
