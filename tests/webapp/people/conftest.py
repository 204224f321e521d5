"""The counter stores the limits run on: every store-level and policy test runs on the
memory store (one process) and on Redis (several), which must agree."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from webapp.database.redis import connect_redis
from webapp.people.counters.base import Counters
from webapp.people.counters.memory import MemoryCounters
from webapp.people.counters.redis import RedisCounters


@pytest.fixture(params=["memory", "redis"])
async def counters(request: pytest.FixtureRequest) -> AsyncIterator[Counters]:
    """An empty store of each kind (Redis: the test's own key prefix)."""
    if request.param == "memory":
        yield MemoryCounters()
        return
    client = connect_redis(request.getfixturevalue("redis_server"))
    try:
        yield RedisCounters(client, request.getfixturevalue("redis_prefix"))
    finally:
        await client.aclose()


@pytest.fixture
async def processes(redis_server: str, redis_prefix: str) -> AsyncIterator[list[RedisCounters]]:
    """Two server processes' stores on one Redis: a client (and connections) each."""
    clients = [connect_redis(redis_server) for _ in range(2)]
    try:
        yield [RedisCounters(client, redis_prefix) for client in clients]
    finally:
        for client in clients:
            await client.aclose()
