"""Redis, the store several server processes share (the bus, shared counters).

One client per process, made by the app factory when ``TAGWALL_BUS=redis``; every key is
named under ``TAGWALL_REDIS_PREFIX`` by :func:`redis_key`.
"""

from __future__ import annotations

from redis.asyncio import Redis


def connect_redis(url: str) -> Redis:
    """A client for ``url`` (connections open on first use, so this does no I/O).

    Replies stay bytes: event frames are passed on as they are, decoded once.
    """
    return Redis.from_url(url, health_check_interval=10, socket_keepalive=True)


def redis_key(prefix: str, *parts: str) -> str:
    """``prefix:part:part``: one naming rule for every key tagwall writes."""
    return ":".join((prefix, *parts))
