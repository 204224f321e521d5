"""Fan-out: how fast a published wall event reaches N tile sockets, at what CPU cost,
and how that compares with what the least code does on the same machine.

One run measures these targets, one after another, under the same client load:

* ``starlette`` and ``websockets``: floors (:mod:`benchmarks.floors`), one process
  each; Starlette under uvicorn with one ``send_text`` per socket, and the
  ``websockets`` library's own server with its ``broadcast()``.
* ``tagwall memory``: one ``tagwall serve`` (SQLite, memory bus) serving the
  50-display ``hiperwall``; the operator API publishes light events.
* ``tagwall redis, 2 processes``: two ``tagwall serve`` on one fresh PostgreSQL
  database and one Redis (``TAGWALL_BUS=redis``, a key prefix of the run's own),
  the tiles split evenly between them, every event published through the first.
  Skipped, with the reason in the result, when Redis or PostgreSQL does not answer.

For each target a stream of ``EVENTS`` events, one every ``EVENT_INTERVAL_S``, runs
without clients (what publishing costs alone), then with each of ``CLIENT_COUNTS``
websocket clients in another process (spread round-robin over the tiles and the
target's processes) that say hello and then time every event. The clients offer
permessage-deflate, as browsers do, and every target accepts it: each delivery
compresses the frame for its socket, on the floors too.

* latency = client receive time - the server's publish stamp. The server stamps
  ``apply_at = publish time + apply lead`` in whole milliseconds, so a figure may
  read up to 1 ms high, never low. ``latency_ms`` is over every delivery,
  ``last_tile_ms`` over each event's last delivery (across processes).
* CPU per delivery = the target's server processes' CPU (user + system, from
  ``/proc``) over the stream / deliveries; ``marginal`` subtracts the run without
  clients and is the fan-out cost.
* ``comparison``, per client count: each tagwall target's marginal CPU as a multiple
  of the better floor's, and its p99 latency beside the floors' (and as a multiple).

``python -m benchmarks.fanout --events 20`` runs a short one and prints it.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import multiprocessing
import statistics
import sys
import tempfile
import time
import uuid
from collections import defaultdict
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import httpx

from benchmarks.measuring import POSTGRES_URL, REDIS_URL, cpu_seconds, percentile, unreachable
from webapp.cli.testing import ServerProcess, free_port

WALL = "hiperwall"
TILES = [f"r{row}c{col}" for row in range(1, 6) for col in range(1, 11)]
CLIENT_COUNTS = (50, 200)
EVENTS = 300
EVENT_INTERVAL_S = 0.02
APPLY_LEAD_MS = 250  # the floors stamp with the same lead (benchmarks.floors)
SECRET = "benchmark-secret-key-0123456789"
FLOORS = ("starlette", "websockets")
GOALS = {"p99_ms_at_50": 5.0, "cpu_us_per_delivery": 10.0}
ROOT = Path(__file__).resolve().parents[1]


# --- clients -----------------------------------------------------------------------------


def client_process(urls: list[str], events: int, pipe: Connection) -> None:
    asyncio.run(run_clients(urls, events, pipe))


async def run_clients(urls: list[str], events: int, pipe: Connection) -> None:
    """Connect every tile, report ready, then time ``events`` events on each; report
    (version, latency ms) per delivery."""
    from websockets.asyncio.client import connect

    sockets = [await connect(url, max_size=2**20) for url in urls]
    for socket in sockets:
        await socket.send(json.dumps({"type": "hello", "last_version": None}))
    for socket in sockets:
        snapshot = json.loads(await socket.recv())
        assert snapshot["type"] == "snapshot", snapshot
    pipe.send("ready")
    deliveries: list[tuple[int, float]] = []

    async def listen(socket: Any) -> None:
        received = 0
        while received < events:
            frame = await socket.recv()
            now_ms = time.time_ns() / 1e6
            message = json.loads(frame)
            if message["type"] == "event":
                deliveries.append(
                    (message["version"], now_ms - message["apply_at"] + APPLY_LEAD_MS)
                )
                received += 1

    await asyncio.wait_for(asyncio.gather(*(listen(s) for s in sockets)), timeout=300)
    for socket in sockets:
        await socket.close()
    pipe.send(deliveries)


# --- targets -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Target:
    """A server under test: its processes, a tile's websocket URL on one of them, and
    how to publish one event (an HTTP request to the first)."""

    servers: list[ServerProcess]
    tile_url: Callable[[ServerProcess, str], str]
    publish: Callable[[httpx.Client], None]

    @property
    def pids(self) -> list[int]:
        return [server.pid for server in self.servers]

    def tile_urls(self, clients: int) -> list[str]:
        """Round-robin over the tiles and the processes."""
        servers = self.servers
        return [
            self.tile_url(servers[index % len(servers)], TILES[index % len(TILES)])
            for index in range(clients)
        ]


@contextmanager
def running(servers: list[ServerProcess]) -> Iterator[list[ServerProcess]]:
    """Start the servers one after another (the first alone migrates a shared
    database), and stop them all."""
    try:
        for server in servers:
            server.start()
        yield servers
    finally:
        for server in servers:
            server.stop()


@contextmanager
def floor(scratch: Path, command: Callable[[int], list[str]]) -> Iterator[Target]:
    """A floor (``benchmarks.floors``) started with ``command(port)``."""
    port = free_port()
    server = ServerProcess(
        var_dir=scratch,
        database_url="",
        secret=SECRET,
        port=port,
        command=command(port),
        extra_env={"PYTHONPATH": str(ROOT)},
    )

    def publish(client: httpx.Client) -> None:
        client.post(f"{server.url}/publish").raise_for_status()

    def tile_url(process: ServerProcess, tile: str) -> str:
        return f"{process.url.replace('http', 'ws', 1)}/ws/{tile}"

    with running([server]):
        yield Target([server], tile_url, publish)


def starlette_floor(scratch: Path) -> AbstractContextManager[Target]:
    # uvicorn as `tagwall serve` runs it (webapp.cli.commands.serve; 4096: TAGWALL_MAX_FRAME_BYTES)
    return floor(
        scratch,
        lambda port: [
            *(sys.executable, "-m", "uvicorn", "benchmarks.floors:starlette_app"),
            *("--host", "127.0.0.1", "--port", str(port), "--log-level", "info"),
            *("--ws-max-size", "4096", "--no-proxy-headers"),
        ],
    )


def websockets_floor(scratch: Path) -> AbstractContextManager[Target]:
    return floor(
        scratch, lambda port: [sys.executable, "-m", "benchmarks.floors", "--port", str(port)]
    )


@contextmanager
def tagwall(
    scratch: Path, database_url: str, processes: int, env: dict[str, str]
) -> Iterator[Target]:
    """``processes`` ``tagwall serve`` on one database; light changes through the first.
    The grid layer flips with every change after the first, so each one is an event."""
    servers = [
        ServerProcess(
            var_dir=scratch / f"var{index}",
            database_url=database_url,
            secret=SECRET,
            extra_env={"TAGWALL_APPLY_LEAD_MS": str(APPLY_LEAD_MS), **env},
        )
        for index in range(processes)
    ]
    flips = itertools.count()

    def publish(client: httpx.Client) -> None:
        servers[0].change(WALL, {"layers": {"grid": next(flips) % 2 == 1}}, client)

    def tile_url(server: ServerProcess, tile: str) -> str:
        return server.tile_url(WALL, tile, scheme="ws")

    with running(servers):
        yield Target(servers, tile_url, publish)


def tagwall_memory(scratch: Path) -> AbstractContextManager[Target]:
    return tagwall(scratch, f"sqlite:///{scratch / 'bench.db'}", 1, {})


@contextmanager
def tagwall_redis(scratch: Path, redis_url: str, postgres_url: str) -> Iterator[Target]:
    from redis import Redis

    from webapp.cli.testing import fresh_database

    prefix = f"tagwall-bench:{uuid.uuid4().hex[:12]}"
    env = {"TAGWALL_BUS": "redis", "TAGWALL_REDIS_URL": redis_url, "TAGWALL_REDIS_PREFIX": prefix}
    try:
        with (
            fresh_database(postgres_url, scratch, name="tagwall_bench") as database_url,
            tagwall(scratch, database_url, 2, env) as target,
        ):
            yield target
    finally:
        with Redis.from_url(redis_url) as redis:
            for key in redis.scan_iter(f"{prefix}:*"):
                redis.delete(key)


# --- measuring ---------------------------------------------------------------------------


def publish_stream(target: Target, events: int) -> float:
    """Publish ``events`` events at a steady rate; returns the servers' CPU seconds."""
    with httpx.Client(timeout=10) as client:
        before = cpu_seconds(target.pids)
        start = time.perf_counter()
        for index in range(events):
            target.publish(client)
            pause = start + (index + 1) * EVENT_INTERVAL_S - time.perf_counter()
            if pause > 0:
                time.sleep(pause)
        return cpu_seconds(target.pids) - before


def spread(values: list[float]) -> dict[str, float]:
    return {
        "p50": round(statistics.median(values), 3),
        "p99": round(percentile(values, 0.99), 3),
        "max": round(max(values), 3),
    }


def measure(target: Target, clients: int, events: int) -> dict[str, Any]:
    """One stream with ``clients`` clients (none: the publishing cost alone)."""
    if clients == 0:
        cpu = publish_stream(target, events)
        return {"events": events, "server_cpu_s": round(cpu, 2)}
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe()
    process = context.Process(
        target=client_process, args=(target.tile_urls(clients), events, theirs)
    )
    process.start()
    if not ours.poll(120) or ours.recv() != "ready":
        raise RuntimeError("the clients did not connect")
    cpu = publish_stream(target, events)
    if not ours.poll(300):
        raise RuntimeError("the clients did not receive every event")
    deliveries: list[tuple[int, float]] = ours.recv()
    process.join(30)
    last: dict[int, float] = defaultdict(float)
    for version, latency in deliveries:
        last[version] = max(last[version], latency)
    return {
        "clients": clients,
        "events": events,
        "deliveries": len(deliveries),
        "latency_ms": spread([latency for _, latency in deliveries]),
        "last_tile_ms": spread(list(last.values())),
        "server_cpu_s": round(cpu, 2),
        "server_cpu_us_per_delivery": round(cpu / len(deliveries) * 1e6, 2),
    }


def measure_target(
    target: Target, client_counts: Sequence[int], events: int, description: str
) -> dict[str, Any]:
    """The baseline, then a run per client count, each with its marginal CPU."""
    with httpx.Client(timeout=60) as client:
        target.publish(client)  # warm up: the first change may load what later ones reuse
    baseline = measure(target, 0, events)
    runs = [measure(target, count, events) for count in client_counts]
    for run_ in runs:
        extra = max(0.0, run_["server_cpu_s"] - baseline["server_cpu_s"])
        run_["server_cpu_us_per_delivery_marginal"] = round(extra / run_["deliveries"] * 1e6, 2)
    return {
        "description": description,
        "server_processes": len(target.servers),
        "baseline": baseline,
        "runs": runs,
    }


def ratio(value: float, floor_value: float) -> float | None:
    return round(value / floor_value, 2) if floor_value > 0 else None


def compare(targets: dict[str, dict[str, Any]], client_counts: Sequence[int]) -> dict[str, Any]:
    """Per client count: each tagwall target's marginal CPU over the better floor's,
    and its p99 beside the floors'."""
    runs = {
        name: {run_["clients"]: run_ for run_ in figures["runs"]}
        for name, figures in targets.items()
        if "runs" in figures
    }
    floors = [name for name in FLOORS if name in runs]
    comparison: dict[str, Any] = {}
    for clients in client_counts:
        best = min(
            floors, key=lambda name: runs[name][clients]["server_cpu_us_per_delivery_marginal"]
        )
        best_cpu = runs[best][clients]["server_cpu_us_per_delivery_marginal"]
        floor_p99 = {name: runs[name][clients]["latency_ms"]["p99"] for name in floors}
        tagwall_runs = {
            name: by_count[clients] for name, by_count in runs.items() if name not in floors
        }
        comparison[str(clients)] = {
            "better_floor": best,
            "floor_marginal_cpu_us_per_delivery": best_cpu,
            "floor_p99_ms": floor_p99,
            "tagwall": {
                name: {
                    "marginal_cpu_x_better_floor": ratio(
                        mine["server_cpu_us_per_delivery_marginal"], best_cpu
                    ),
                    "p99_ms": mine["latency_ms"]["p99"],
                    "p99_x_floor": {
                        floor_name: ratio(mine["latency_ms"]["p99"], p99)
                        for floor_name, p99 in floor_p99.items()
                    },
                }
                for name, mine in tagwall_runs.items()
            },
        }
    return comparison


def run(
    events: int = EVENTS,
    client_counts: Sequence[int] = CLIENT_COUNTS,
    redis_url: str = REDIS_URL,
    postgres_url: str = POSTGRES_URL,
) -> dict[str, Any]:
    targets: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="tagwall-fanout-") as scratch:
        folder = Path(scratch)
        plan: list[tuple[str, Callable[[Path], AbstractContextManager[Target]], str]] = [
            ("starlette", starlette_floor, "Starlette under uvicorn, send_text to each socket"),
            ("websockets", websockets_floor, "the websockets library's server, broadcast()"),
            ("tagwall memory", tagwall_memory, "one tagwall serve, SQLite, memory bus"),
            (
                "tagwall redis, 2 processes",
                lambda path: tagwall_redis(path, redis_url, postgres_url),
                "two tagwall serve, one PostgreSQL database, Redis bus; tiles split "
                "evenly, published through the first",
            ),
        ]
        for name, start, description in plan:
            if name.startswith("tagwall redis") and (
                reason := unreachable(redis_url, postgres_url)
            ):
                targets[name] = {"description": description, "skipped": reason}
                continue
            print(f"   {name} ...", flush=True)
            path = folder / name.replace(" ", "-").replace(",", "")
            with start(path) as target:
                targets[name] = measure_target(target, client_counts, events, description)
    return {
        "wall": WALL,
        "events": events,
        "event_interval_ms": EVENT_INTERVAL_S * 1000,
        "apply_lead_ms": APPLY_LEAD_MS,
        "targets": targets,
        "comparison": compare(targets, client_counts),
        "goals": GOALS,
    }


def summary(result: dict[str, Any]) -> str:
    lines = []
    for name, figures in result["targets"].items():
        if "skipped" in figures:
            lines.append(f"   {name}: skipped ({figures['skipped']})")
            continue
        lines.append(f"   {name}: {figures['baseline']['server_cpu_s']:.2f} s CPU without clients")
        for run_ in figures["runs"]:
            latency, last = run_["latency_ms"], run_["last_tile_ms"]
            lines.append(
                f"     {run_['clients']:>4} clients: p50 {latency['p50']:.2f} ms, "
                f"p99 {latency['p99']:.2f} ms, max {latency['max']:.2f} ms "
                f"(last tile p99 {last['p99']:.2f} ms); server CPU "
                f"{run_['server_cpu_us_per_delivery']:.1f} us/delivery "
                f"({run_['server_cpu_us_per_delivery_marginal']:.1f} marginal)"
            )
    for clients, row in result["comparison"].items():
        p99s = ", ".join(f"{name} {p99:.2f}" for name, p99 in row["floor_p99_ms"].items())
        for name, mine in row["tagwall"].items():
            times = mine["marginal_cpu_x_better_floor"]
            lines.append(
                f"   {clients} clients, {name}: marginal CPU "
                f"{'n/a' if times is None else f'{times}x'} the better floor's "
                f"({row['better_floor']}); p99 {mine['p99_ms']:.2f} ms against {p99s} ms"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.fanout", description=__doc__)
    parser.add_argument("--events", type=int, default=EVENTS)
    parser.add_argument("--clients", type=int, nargs="+", default=list(CLIENT_COUNTS))
    parser.add_argument("--redis-url", default=REDIS_URL)
    parser.add_argument("--database-url", default=POSTGRES_URL, help="a PostgreSQL server's URL")
    args = parser.parse_args(argv)
    result = run(args.events, args.clients, args.redis_url, args.database_url)
    print(json.dumps(result, indent=2))
    print(summary(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
