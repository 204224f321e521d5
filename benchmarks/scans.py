"""Scan resolution: ``GET /t/{CODE}`` throughput beside a bare Starlette endpoint.

One server process (uvicorn, as ``tagwall serve`` runs it) serves the tagwall app with a
bare ``/hello`` route added, so both are measured on the same server in the same run.
Clients in another process keep ``CONNECTIONS`` HTTP/1.1 keep-alive connections busy
for ``SECONDS`` each; the client is raw asyncio (no HTTP library) so it costs the shared
CPUs as little as possible. A resolution looks the code up, checks it, records the scan
in the database and renders the app's phone page, so the ratio is what the whole
path costs against the framework's floor. Two resolutions are measured: a first scan
(no cookie: the Student registration code, which makes a visitor each time) and a
scan by a phone already in the room (its session cookie, one of the setup pattern's
codes), which is what most scans in a class are.

The aim is a ratio of at least ``TARGET_RATIO``: the scan path should cost little more
than the framework itself (the code cache and batched scan writes of
:mod:`webapp.tags.scanning` are what bring it there).
"""

from __future__ import annotations

import asyncio
import multiprocessing
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
from fastapi import FastAPI
from starlette.requests import Request
from starlette.responses import PlainTextResponse

from webapp.cli.testing import ServerProcess
from webapp.database.migrate import upgrade
from webapp.server.app import create_app
from webapp.tags.registry import wall_tags

CONNECTIONS = 16
SECONDS = 5.0
TARGET_RATIO = 0.5


def app_with_hello() -> FastAPI:
    """The tagwall app plus the bare endpoint it is compared with."""
    app = create_app()

    async def hello(_request: Request) -> PlainTextResponse:
        return PlainTextResponse("hello")

    app.add_route("/hello", hello)
    return app


async def _hammer(port: int, path: str, seconds: float, cookie: str) -> tuple[int, int]:
    """Requests completed (and how many were not 200) on keep-alive connections."""
    sent = f"Cookie: {cookie}\r\n" if cookie else ""
    request = f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\nUser-Agent: bench\r\n{sent}\r\n".encode()
    deadline = time.perf_counter() + seconds
    done = failed = 0

    async def connection() -> None:
        nonlocal done, failed
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        while time.perf_counter() < deadline:
            writer.write(request)
            head = await reader.readuntil(b"\r\n\r\n")
            length = int(
                next(
                    line.split(b":", 1)[1]
                    for line in head.split(b"\r\n")
                    if line.lower().startswith(b"content-length:")
                )
            )
            await reader.readexactly(length)
            done += 1
            failed += not head.startswith(b"HTTP/1.1 200")
        writer.close()

    await asyncio.gather(*(connection() for _ in range(CONNECTIONS)))
    return done, failed


def _client(port: int, path: str, seconds: float, cookie: str, queue: Any) -> None:
    queue.put(asyncio.run(_hammer(port, path, seconds, cookie)))


def measure(port: int, path: str, seconds: float = SECONDS, cookie: str = "") -> dict[str, float]:
    """Requests per second on ``path`` from another process (``cookie``: the phone's)."""
    queue: Any = multiprocessing.get_context("spawn").Queue()
    process = multiprocessing.get_context("spawn").Process(
        target=_client, args=(port, path, seconds, cookie, queue)
    )
    process.start()
    done, failed = queue.get()
    process.join()
    return {"requests": done, "failed": failed, "per_second": round(done / seconds, 1)}


def run() -> dict[str, Any]:
    with tempfile.TemporaryDirectory() as tmp:
        database_url = f"sqlite:///{Path(tmp) / 'bench.db'}"
        upgrade(database_url)
        server = ServerProcess(
            var_dir=Path(tmp) / "var",
            database_url=database_url,
            secret="benchmark-secret-key-0123456789",
            extra_env={
                # one client address makes every request: lift the per-phone limits
                "TAGWALL_SCAN_RATE_PER_MINUTE": "100000000",
                "TAGWALL_SCAN_RATE_PER_ADDRESS_PER_MINUTE": "100000000",
            },
        )
        server.command = [
            sys.executable,
            "-m",
            "uvicorn",
            "--factory",
            "benchmarks.scans:app_with_hello",
            "--host",
            "127.0.0.1",
            "--port",
            str(server.port),
            "--log-level",
            "warning",
        ]
        server.start()
        try:
            from webapp.database.connection import Database

            db = Database(database_url)
            tags = {t.name: t.code for t in wall_tags(db, "demo")}
            db.dispose()
            register, setup = tags["register-student"], tags["setup-r1c1"]
            phone = httpx.get(f"{server.url}/t/{register}", timeout=30)
            cookie = "; ".join(f"{name}={value}" for name, value in phone.cookies.items())
            measure(server.port, "/hello", 1.0)  # warm up
            hello = measure(server.port, "/hello")
            first = measure(server.port, f"/t/{register}")
            again = measure(server.port, f"/t/{setup}", cookie=cookie)
        finally:
            server.stop()
    ratio = again["per_second"] / hello["per_second"]
    return {
        "connections": CONNECTIONS,
        "seconds": SECONDS,
        "database": "sqlite",
        "hello": hello,
        "resolve": first,
        "resolve_in_the_room": again,
        "first_scan_ratio": round(first["per_second"] / hello["per_second"], 3),
        "ratio": round(ratio, 3),
        "target_ratio": TARGET_RATIO,
        "meets_target": ratio >= TARGET_RATIO,
    }


def summary(result: dict[str, Any]) -> str:
    first, again = result["resolve"], result["resolve_in_the_room"]
    return (
        f"   hello {result['hello']['per_second']:.0f}/s; a first scan (registering)"
        f" {first['per_second']:.0f}/s (failed {first['failed']}, ratio"
        f" {result['first_scan_ratio']:.2f}); a phone in the room {again['per_second']:.0f}/s"
        f" (failed {again['failed']}): ratio {result['ratio']:.2f}"
        f" (aim >= {result['target_ratio']})"
    )
