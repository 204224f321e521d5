"""What several benchmarks measure alike: percentiles, the CPU and memory of server
processes, and whether the machine's PostgreSQL and Redis are there for the scale-out
runs."""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import re
from collections import defaultdict
from collections.abc import Sequence
from multiprocessing.connection import Connection
from pathlib import Path

REDIS_URL = "redis://127.0.0.1:6379/0"
POSTGRES_URL = "postgresql+psycopg://postgres@127.0.0.1:5432/postgres"
"""The machine's servers (the README's CI uses them); a fresh database is made on it."""


def percentile(values: Sequence[float], fraction: float) -> float:
    """The nearest-rank percentile: the smallest value with at least ``fraction`` of
    the values at or below it (p100 is the maximum)."""
    if not values:
        raise ValueError("no values")
    ordered = sorted(values)
    rank = max(1, math.ceil(fraction * len(ordered)))
    return ordered[rank - 1]


def process_tree(pid: int) -> list[int]:
    """``pid`` and every process below it (uvicorn's workers)."""
    children: dict[int, list[int]] = defaultdict(list)
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError):
                parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
                children[parent].append(int(entry.name))
    tree, todo = [], [pid]
    while todo:
        current = todo.pop()
        tree.append(current)
        todo.extend(children.get(current, []))
    return tree


def cpu_seconds(pids: Sequence[int]) -> float:
    """User + system CPU time of these processes, all their threads (Linux ``/proc``;
    a process gone meanwhile counts nothing)."""
    total = 0
    for pid in pids:
        with contextlib.suppress(OSError):
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += int(fields[11]) + int(fields[12])
    return total / os.sysconf("SC_CLK_TCK")


MEMORY_FIELDS = {"rss": "VmRSS", "anon": "RssAnon", "file": "RssFile", "peak": "VmHWM"}


def memory_kb(pids: Sequence[int]) -> dict[str, int]:
    """Resident memory of these processes, summed, in kB (Linux ``/proc``): all of it
    (``rss``), its anonymous part (``anon``: the heap, where a leak grows), its part
    backed by files (``file``: libraries, mapped files, which pages in as it is used)
    and the peak of the whole (``peak``). A process gone meanwhile counts nothing."""
    total = dict.fromkeys(MEMORY_FIELDS, 0)
    for pid in pids:
        with contextlib.suppress(OSError):
            status = Path(f"/proc/{pid}/status").read_text()
            for name, field in MEMORY_FIELDS.items():
                found = re.search(rf"^{field}:\s+(\d+) kB", status, re.MULTILINE)
                total[name] += int(found.group(1)) if found else 0
    return total


def unreachable(redis_url: str, postgres_url: str) -> str | None:
    """Why Redis or PostgreSQL cannot serve a scale-out run here, or None."""
    from redis import Redis, RedisError
    from sqlalchemy import create_engine
    from sqlalchemy.exc import DBAPIError

    try:
        with Redis.from_url(redis_url, socket_connect_timeout=3) as redis:
            redis.ping()
    except RedisError as error:
        return f"Redis at {redis_url} does not answer: {error}"
    engine = create_engine(postgres_url, connect_args={"connect_timeout": 3})
    try:
        with engine.connect():
            pass
    except DBAPIError as error:
        return f"PostgreSQL at {postgres_url} does not answer: {' '.join(str(error.orig).split())}"
    finally:
        engine.dispose()
    return None


def told_to_stop(pipe: Connection) -> asyncio.Event:
    """An event set by any message from the parent process on ``pipe`` (a load
    generator's or a tile client's signal to wrap up; call in its event loop)."""
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()

    def heard() -> None:
        loop.remove_reader(pipe.fileno())
        stop.set()

    loop.add_reader(pipe.fileno(), heard)
    return stop
