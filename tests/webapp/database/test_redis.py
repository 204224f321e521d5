"""The Redis client: one naming rule for keys, a client that talks to a real server."""

from __future__ import annotations

import asyncio

from webapp.database.redis import connect_redis, redis_key


def test_keys_are_named_under_the_prefix() -> None:
    assert redis_key("tagwall", "wall", "demo", "events") == "tagwall:wall:demo:events"


def test_a_client_reaches_the_server(redis_server: str, redis_prefix: str) -> None:
    async def round_trip() -> bytes | None:
        client = connect_redis(redis_server)
        try:
            key = redis_key(redis_prefix, "probe")
            await client.set(key, b"ok", ex=60)
            value: bytes | None = await client.get(key)
            await client.delete(key)
            return value
        finally:
            await client.aclose()

    assert asyncio.run(round_trip()) == b"ok"
