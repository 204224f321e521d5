"""Redis, the store several server processes share (the bus, shared counters).

One client per process, made by the app factory when ``TAGWALL_BUS=redis``; every key is
named under ``TAGWALL_REDIS_PREFIX`` by :func:`redis_key`.
"""

from __future__ import annotations

import re
from urllib.parse import urlsplit

from redis.asyncio import Redis
from redis.asyncio.retry import Retry
from redis.backoff import ExponentialWithJitterBackoff, NoBackoff
from redis.exceptions import RedisError

CONNECT_TIMEOUT_S = 5.0
"""How long opening a connection may take: a Redis host that drops packets fails fast."""
SOCKET_TIMEOUT_S = 15.0
"""How long any reply may take; above the bus reader's blocking read (5 s), so only a
connection that died silently times out."""
RETRIES = 3
"""Retries of a command on a dropped connection (a killed connection, a failover) within
half a second or so; a longer outage reaches the caller, which knows what to do: the
bus reader reconnects with its own backoff, a change answers 503."""


def connect_redis(url: str, *, client_name: str = "tagwall") -> Redis:
    """A client for ``url`` (connections open on first use, so this does no I/O).

    Replies stay bytes: event frames are passed on as they are, decoded once. Every
    connection is named ``client_name``, so ``CLIENT LIST`` shows which are tagwall's.
    """
    return Redis.from_url(
        url,
        client_name=client_name,
        health_check_interval=10,
        socket_keepalive=True,
        socket_connect_timeout=CONNECT_TIMEOUT_S,
        socket_timeout=SOCKET_TIMEOUT_S,
        retry=Retry(ExponentialWithJitterBackoff(base=0.01, cap=0.25), RETRIES),
    )


def redis_key(prefix: str, *parts: str) -> str:
    """``prefix:part:part``: one naming rule for every key tagwall writes."""
    return ":".join((prefix, *parts))


_QUERY_PASSWORD = re.compile(r"([?&]password=)[^&]*")


def shown_url(url: str) -> str:
    """``url`` with its password hidden (``redis://user:***@host``, ``?password=***``), for
    messages and logs."""
    password = urlsplit(url).password
    shown = url.replace(f":{password}@", ":***@", 1) if password else url
    return _QUERY_PASSWORD.sub(r"\1***", shown)


async def redis_problem(url: str) -> str | None:
    """None when the Redis at ``url`` answers, else one line saying what is wrong (for
    an operator starting a server with ``TAGWALL_BUS=redis``). Asks once, no retries."""
    try:
        client = Redis.from_url(
            url, socket_connect_timeout=CONNECT_TIMEOUT_S, retry=Retry(NoBackoff(), 0)
        )
    except ValueError as error:
        return f"TAGWALL_REDIS_URL {shown_url(url)} is not a Redis URL tagwall can use ({error})"
    try:
        await client.ping()
    except (RedisError, OSError) as error:
        reason = str(error).strip().splitlines()
        first = reason[0] if reason else type(error).__name__
        return f"cannot use Redis at {shown_url(url)} (TAGWALL_REDIS_URL): {first}"
    finally:
        await client.aclose()
    return None
