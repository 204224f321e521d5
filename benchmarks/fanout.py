"""Fan-out: how fast a published wall event reaches N tile sockets, and at what CPU cost.

A real ``tagwall serve`` process serves the 50-display ``hiperwall``; N websocket
clients (in another process, spread round-robin over its tiles) say hello and
then time every event. The operator API publishes a stream of light events.

* latency = client receive time - publish time. The server stamps
  ``apply_at = publish time + apply lead`` in whole milliseconds, so a figure may
  read up to 1 ms high, never low.
* CPU per delivery = server process CPU (user + system, from ``/proc``) over the
  stream / deliveries. The run without clients measures what committing and
  publishing costs on its own; ``marginal`` subtracts it and is the fan-out cost.
"""

from __future__ import annotations

import asyncio
import json
import multiprocessing
import os
import statistics
import tempfile
import time
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import httpx

from webapp.testing import ServerProcess

WALL = "hiperwall"
TILES = [f"r{row}c{col}" for row in range(1, 6) for col in range(1, 11)]
CLIENT_COUNTS = (50, 200)
EVENTS = 300
EVENT_INTERVAL_S = 0.02
APPLY_LEAD_MS = 250
TARGETS = {"p99_ms_at_50": 5.0, "cpu_us_per_delivery": 10.0}


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def client_process(urls: list[str], events: int, pipe: Connection) -> None:
    asyncio.run(run_clients(urls, events, pipe))


async def run_clients(urls: list[str], events: int, pipe: Connection) -> None:
    """Connect every tile, report ready, then time ``events`` events on each."""
    from websockets.asyncio.client import connect

    sockets = [await connect(url, max_size=2**20) for url in urls]
    for socket in sockets:
        await socket.send(json.dumps({"type": "hello", "last_version": None}))
    for socket in sockets:
        snapshot = json.loads(await socket.recv())
        assert snapshot["type"] == "snapshot", snapshot
    pipe.send("ready")
    latencies: list[float] = []

    async def listen(socket: Any) -> None:
        received = 0
        while received < events:
            frame = await socket.recv()
            now_ms = time.time_ns() / 1e6
            message = json.loads(frame)
            if message["type"] == "event":
                latencies.append(now_ms - (message["apply_at"] - APPLY_LEAD_MS))
                received += 1

    await asyncio.wait_for(asyncio.gather(*(listen(s) for s in sockets)), timeout=300)
    for socket in sockets:
        await socket.close()
    pipe.send(latencies)


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def publish_stream(server: ServerProcess) -> float:
    """Publish ``EVENTS`` light events at a steady rate; returns server CPU seconds used."""
    with httpx.Client(timeout=10) as client:
        server.change(WALL, {"layers": {"warmup": True}}, client)
        before = cpu_seconds(server.pid)
        start = time.perf_counter()
        for index in range(EVENTS):
            server.change(WALL, {"layers": {"grid": index % 2 == 0}}, client)
            pause = start + (index + 1) * EVENT_INTERVAL_S - time.perf_counter()
            if pause > 0:
                time.sleep(pause)
        return cpu_seconds(server.pid) - before


def measure(server: ServerProcess, clients: int) -> dict[str, Any]:
    if clients == 0:
        return {"clients": 0, "events": EVENTS, "server_cpu_s": publish_stream(server)}
    urls = [server.tile_url(WALL, TILES[i % len(TILES)], scheme="ws") for i in range(clients)]
    context = multiprocessing.get_context("spawn")
    ours, theirs = context.Pipe()
    process = context.Process(target=client_process, args=(urls, EVENTS, theirs))
    process.start()
    if not ours.poll(120) or ours.recv() != "ready":
        raise RuntimeError("the clients did not connect")
    cpu = publish_stream(server)
    if not ours.poll(300):
        raise RuntimeError("the clients did not receive every event")
    latencies: list[float] = ours.recv()
    process.join(30)
    deliveries = len(latencies)
    return {
        "clients": clients,
        "events": EVENTS,
        "deliveries": deliveries,
        "latency_ms": {
            "p50": round(statistics.median(latencies), 3),
            "p99": round(percentile(latencies, 0.99), 3),
            "max": round(max(latencies), 3),
        },
        "server_cpu_s": cpu,
        "server_cpu_us_per_delivery": round(cpu / deliveries * 1e6, 2),
    }


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="tagwall-bench-") as scratch:
        var = Path(scratch)
        server = ServerProcess(
            var_dir=var,
            database_url=f"sqlite:///{var / 'bench.db'}",
            secret="benchmark-secret-key-0123456789",
            extra_env={"TAGWALL_APPLY_LEAD_MS": str(APPLY_LEAD_MS)},
        )
        server.start()
        try:
            baseline = measure(server, 0)
            runs = [measure(server, count) for count in CLIENT_COUNTS]
        finally:
            server.stop()
    for result in runs:
        extra = result["server_cpu_s"] - baseline["server_cpu_s"]
        result["server_cpu_us_per_delivery_marginal"] = round(
            max(0.0, extra) / result["deliveries"] * 1e6, 2
        )
    return {
        "wall": WALL,
        "event_interval_ms": EVENT_INTERVAL_S * 1000,
        "baseline_server_cpu_s": baseline["server_cpu_s"],
        "runs": runs,
        "targets": TARGETS,
    }


def summary(result: dict[str, Any]) -> str:
    lines = []
    for run_ in result["runs"]:
        latency = run_["latency_ms"]
        lines.append(
            f"   {run_['clients']:>4} clients: p50 {latency['p50']:.2f} ms, "
            f"p99 {latency['p99']:.2f} ms, max {latency['max']:.2f} ms; server CPU "
            f"{run_['server_cpu_us_per_delivery']:.1f} us/delivery "
            f"({run_['server_cpu_us_per_delivery_marginal']:.1f} marginal)"
        )
    return "\n".join(lines)
