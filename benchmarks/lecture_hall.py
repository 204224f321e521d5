"""A lecture hall of phones on one server, while the tiles of another wall keep changing.

One ``tagwall serve`` (its processes are measured) puts the brain atlas on the ``demo``
wall. Phones arrive uniformly over a period, each a browser of its own (an httpx
client with its own cookie jar and connection) in load-generator processes apart from
the server's: it scans the Student registration code, then three of the placed quiz
pins; each pin's page is the quiz form, whose answer it posts with the form's CSRF
token and, as a browser does, follows the 303 to its quiz progress page.

Meanwhile 50 tile websockets of the ``hiperwall`` wall (another process) stay
connected, and the operator API publishes a light change every ``PUBLISH_INTERVAL_S``;
each event is timed from the publisher's request and from the server's stamp
(``apply_at`` - lead) to its arrival at the *last* of the tiles. The same stream runs
for ``IDLE_S`` before the phones come, so the two can be compared.

Measured per step: count, failures (a status that is not 2xx/3xx, or no answer), p50
and p99 latency; the server's CPU per phone request (user + system of every server
process, less what the tiles' stream costs on its own, measured while idle), its
memory; the generator's CPU and lateness (how late phones started against their
schedule: whether the generator kept up); and the cores other processes kept busy
meanwhile (the machine is shared: a figure taken beside others' work says so). After
the hall, each step alone (``STEP_PHONES`` fresh phones one after another) gives
what one request of that step costs the server; and, measured the same way, the least
request the server answers (``floor``: ``GET /healthz``, through the same middleware,
routing, worker thread and pool to one ``SELECT 1``), for the same machine at the same
hour: each step's ``floor_multiple`` is its CPU in floors.

A profile (py-spy, sampling the thread that holds the GIL) sorts the server's CPU by
what it was doing (``WORK``), during the hall and for each step alone.

Only capacity is measured: every phone comes from 127.0.0.1, so the limits per
address are lifted (``LIMIT_SETTINGS``, recorded in the result).

``make bench`` runs ``RUNS``; ``python -m benchmarks.lecture_hall --help`` runs one
scenario with other parameters (phones, period, workers, database, bus) and can
record a py-spy profile of the server meanwhile; ``--server-cpus 0 --load-cpus 1`` is
issue 32's hall (the server on one core, everything else on the other; other work on
the machine still shares both, ``other_cores_busy`` says how much). Several workers
need PostgreSQL and ``--bus redis`` (the server refuses otherwise); every tile then
gets every event, whichever worker it is connected to and whichever published it (an
event some tile never got counts in ``incomplete_events``).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import multiprocessing
import os
import re
import resource
import signal
import ssl
import subprocess
import sys
import tempfile
import time
import uuid
from collections import Counter, defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import TYPE_CHECKING, Any

import httpx

from benchmarks.measuring import (
    POSTGRES_URL,
    REDIS_URL,
    cpu_seconds,
    memory_kb,
    percentile,
    process_tree,
    told_to_stop,
    unreachable,
)

if TYPE_CHECKING:
    from webapp.cli.testing import ServerProcess

PHONE_WALL = "demo"
TILE_WALL = "hiperwall"
TILES = [f"r{row}c{col}" for row in range(1, 6) for col in range(1, 11)]
PINS_PER_PHONE = 3
PUBLISH_INTERVAL_S = 0.5
IDLE_S = 10.0
APPLY_LEAD_MS = 250
WARMUP_PHONES = 3
STEP_PHONES = 300
PROFILE_RATE = 100  # samples a second while the phones come
STEP_PROFILE_RATE = 1000  # samples a second: a step alone takes a second or two
REQUEST_TIMEOUT_S = 120.0
SECRET = "benchmark-secret-key-0123456789"
# Every phone comes from 127.0.0.1. Of the limits on phones, only the budget the
# phones without a cookie share per address touches this path (registration scans,
# 600 a minute by default); the pins are scanned with a cookie (30 a minute each) and
# answers are not rate-limited.
LIMIT_SETTINGS = {"TAGWALL_SCAN_RATE_PER_ADDRESS_PER_MINUTE": "100000000"}
TARGET_CPU_MS_PER_REQUEST = 1.5
STEPS = ("register", "scan", "answer", "progress")
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')
USER_AGENT = "Mozilla/5.0 (iPhone; CPU iPhone OS 17_0 like Mac OS X) lecture-hall-benchmark"


# --- pure parts ------------------------------------------------------------------------


def arrivals(phones: int, period_s: float, start: float) -> list[float]:
    """When each phone arrives: uniformly over the period, the first at ``start``."""
    return [start + period_s * index / phones for index in range(phones)]


@dataclass(frozen=True)
class Sample:
    """One request a phone made."""

    step: str
    latency_ms: float
    status: int  # 0: no answer (a connection error or timeout)

    @property
    def failed(self) -> bool:
        return not 200 <= self.status < 400


def step_figures(samples: Sequence[Sample]) -> dict[str, dict[str, Any]]:
    """Per step: how many, how many failed, latency p50/p99/max (ms) of those answered."""
    figures: dict[str, dict[str, Any]] = {}
    for step in STEPS:
        mine = [s for s in samples if s.step == step]
        if not mine:
            continue
        answered = [s.latency_ms for s in mine if s.status]
        statuses = Counter(str(s.status) for s in mine)
        figures[step] = {
            "count": len(mine),
            "failures": sum(s.failed for s in mine),
            "statuses": dict(sorted(statuses.items())),
            "p50_ms": round(percentile(answered, 0.50), 1) if answered else None,
            "p99_ms": round(percentile(answered, 0.99), 1) if answered else None,
            "max_ms": round(max(answered), 1) if answered else None,
        }
    return figures


# --- phones ----------------------------------------------------------------------------


@dataclass(frozen=True)
class HallCodes:
    """What the phones scan: the registration code and the pins placed on the wall;
    and whether they follow an answer to the progress page it redirects to, as a
    browser does (off: the register/scan/answer path alone)."""

    register: str
    pins: list[str]
    follow_answers: bool = True


async def phone(
    base_url: str, codes: HallCodes, tls: ssl.SSLContext, samples: list[Sample]
) -> None:
    """One phone's visit, as its browser makes it."""

    async def timed(step: str, method: str, path: str, **kwargs: Any) -> httpx.Response | None:
        start = time.perf_counter()
        try:
            response = await browser.request(method, path, **kwargs)
        except httpx.HTTPError:
            samples.append(Sample(step, (time.perf_counter() - start) * 1000, 0))
            return None
        samples.append(Sample(step, (time.perf_counter() - start) * 1000, response.status_code))
        return response

    async with httpx.AsyncClient(
        base_url=base_url,
        verify=tls,  # no CA bundle loaded per phone: the hall speaks plain HTTP
        timeout=REQUEST_TIMEOUT_S,
        headers={"User-Agent": USER_AGENT},
    ) as browser:
        await timed("register", "GET", f"/t/{codes.register}")
        for pin in codes.pins:
            form = await timed("scan", "GET", f"/t/{pin}")
            csrf = _CSRF.search(form.text) if form is not None else None
            if csrf is None:
                continue
            answered = await timed(
                "answer",
                "POST",
                f"/apps/brain/{PHONE_WALL}/pins/{pin}/answer",
                data={"answer": "hippocampus", "csrf": csrf.group(1)},
            )
            if codes.follow_answers and answered is not None and answered.status_code == 303:
                await timed("progress", "GET", answered.headers["location"])


async def phones_at(
    base_url: str, codes: HallCodes, schedule: Sequence[float]
) -> tuple[list[Sample], list[float]]:
    """Every phone of ``schedule`` (wall-clock arrival times): their samples, and how
    late (s) each started against its arrival time."""
    tls = ssl.create_default_context()
    samples: list[Sample] = []
    lateness: list[float] = []

    async def arrive(at: float) -> None:
        await asyncio.sleep(max(0.0, at - time.time()))
        lateness.append(max(0.0, time.time() - at))
        await phone(base_url, codes, tls, samples)

    await asyncio.gather(*(arrive(at) for at in schedule))
    return samples, lateness


def generator_process(
    base_url: str, codes: HallCodes, schedule: list[float], pipe: Connection
) -> None:
    """A load generator's process: its phones, then its results and the CPU they took."""
    before = resource.getrusage(resource.RUSAGE_SELF)
    samples, lateness = asyncio.run(phones_at(base_url, codes, schedule))
    after = resource.getrusage(resource.RUSAGE_SELF)
    pipe.send(
        {
            "samples": [(s.step, s.latency_ms, s.status) for s in samples],
            "lateness": lateness,
            "cpu_s": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
        }
    )


# --- tiles -----------------------------------------------------------------------------


@dataclass
class Published:
    """One light change: when the publisher sent it, and when tiles received it."""

    version: int
    sent_at: float  # publisher's wall clock, s
    acknowledged_at: float
    stamped_at: float = 0.0  # the server's publish time (apply_at - lead), s
    received: list[float] = field(default_factory=list)


def tile_process(
    base_url: str, tile_urls: list[str], operator: dict[str, str], pipe: Connection
) -> None:
    asyncio.run(tiles_and_publisher(base_url, tile_urls, operator, pipe))


async def tiles_and_publisher(
    base_url: str, tile_urls: list[str], operator: dict[str, str], pipe: Connection
) -> None:
    """Connect every tile and report ready; then publish a light change every
    ``PUBLISH_INTERVAL_S`` until told to stop, and report every change's timings."""
    from websockets.asyncio.client import connect

    sockets = [await connect(url, max_size=2**22) for url in tile_urls]
    for socket in sockets:
        await socket.send(json.dumps({"type": "hello", "last_version": None}))
    for socket in sockets:
        snapshot = json.loads(await socket.recv())
        assert snapshot["type"] == "snapshot", snapshot["type"]
    receipts: dict[int, list[float]] = defaultdict(list)
    stamps: dict[int, float] = {}
    dropped = 0

    async def listen(socket: Any) -> None:
        nonlocal dropped
        try:
            async for frame in socket:
                now = time.time()
                message = json.loads(frame)
                if message["type"] == "event":
                    receipts[message["version"]].append(now)
                    stamps[message["version"]] = (message["apply_at"] - APPLY_LEAD_MS) / 1000
        except Exception:  # the server closed it (a tile too slow): counted, not fatal
            dropped += 1

    listeners = [asyncio.create_task(listen(socket)) for socket in sockets]
    pipe.send("ready")
    published: list[Published] = []
    refused: dict[str, list[str]] = {}  # status: the answers' texts
    stop = told_to_stop(pipe)
    async with httpx.AsyncClient(base_url=base_url, headers=operator, timeout=60) as client:
        tick = time.perf_counter()
        while not stop.is_set():
            sent = time.time()
            answer = await client.post(
                f"/api/walls/{TILE_WALL}/state",
                json={"layers": {"grid": len(published) % 2 == 0}},
            )
            if answer.is_success:
                published.append(Published(int(answer.json()["version"]), sent, time.time()))
            else:  # the server refused a change under the hall's load: counted, not fatal
                refused.setdefault(str(answer.status_code), []).append(answer.text[:200])
            tick = max(tick + PUBLISH_INTERVAL_S, time.perf_counter())
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), tick - time.perf_counter())
    pipe.recv()
    await asyncio.sleep(2.0)  # the last events on their way
    for socket in sockets:
        await socket.close()
    await asyncio.gather(*listeners)
    for event in published:
        event.received = sorted(receipts.get(event.version, []))
        event.stamped_at = stamps.get(event.version, 0.0)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    pipe.send(
        {
            "published": [asdict(e) for e in published],
            "refused": refused,
            "dropped": dropped,
            "cpu_s": usage.ru_utime + usage.ru_stime,
        }
    )


def tile_figures(events: Sequence[Published], tiles: int) -> dict[str, Any]:
    """Publish -> delivery at the last tile (ms), from the publisher's request and from
    the server's stamp; events some tile never received are counted apart."""
    complete = [e for e in events if len(e.received) >= tiles]
    from_request = [(e.received[-1] - e.sent_at) * 1000 for e in complete]
    from_stamp = [(e.received[-1] - e.stamped_at) * 1000 for e in complete]
    operator = [(e.acknowledged_at - e.sent_at) * 1000 for e in events]

    def spread(values: list[float]) -> dict[str, float] | None:
        if not values:
            return None
        return {
            "p50": round(percentile(values, 0.5), 1),
            "p99": round(percentile(values, 0.99), 1),
            "max": round(max(values), 1),
        }

    reached = [len(e.received) for e in events]
    return {
        "events": len(events),
        "incomplete_events": len(events) - len(complete),
        "tiles_reached_p50": percentile(reached, 0.5) if reached else None,
        "last_tile_ms_from_request": spread(from_request),
        "last_tile_ms_from_server_stamp": spread(from_stamp),
        "operator_request_ms": spread(operator),
    }


# --- the server ------------------------------------------------------------------------


def machine_busy_seconds() -> float:
    """CPU time every core of the machine has spent busy so far (``/proc/stat``)."""
    fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    idle = fields[3] + fields[4]  # idle, iowait
    return (sum(fields[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def memory_mb(pids: Sequence[int]) -> dict[str, float]:
    """Resident memory now and at its peak (``VmHWM``), summed over the processes."""
    memory = memory_kb(pids)
    return {
        "rss_mb": round(memory["rss"] / 1024, 1),
        "peak_rss_mb": round(memory["peak"] / 1024, 1),
    }


@contextlib.contextmanager
def bench_database(base_url: str | None, scratch: Path) -> Iterator[str]:
    """SQLite in ``scratch``, or a new PostgreSQL database on ``base_url``'s server,
    dropped afterwards."""
    from webapp.cli.testing import fresh_database

    if base_url and not base_url.startswith("postgresql"):
        raise SystemExit(f"--database-url: a postgresql+psycopg:// URL, not {base_url}")
    with fresh_database(base_url or "", scratch, name="tagwall_bench") as url:
        yield url


def hall_codes(database_url: str) -> HallCodes:
    """The registration code and ``PINS_PER_PHONE`` pins placed on the phones' wall."""
    from webapp.database.connection import Database
    from webapp.engine.wall_state import read_state
    from webapp.tags.registry import get_layout, wall_tags

    db = Database(database_url)
    try:
        layout = get_layout(db, PHONE_WALL, read_state(db, PHONE_WALL)[1].tag_layout)
        assert layout is not None, "the brain placed no codes"
        placed = {p["code"] for p in layout.placed}
        tags = wall_tags(db, PHONE_WALL)
        register = next(t.code for t in tags if t.name == "register-student")
        pins = [t.code for t in tags if t.code in placed and t.action == "pin"]
    finally:
        db.dispose()
    if len(pins) < PINS_PER_PHONE:
        raise RuntimeError(f"only {len(pins)} pins are placed on {PHONE_WALL}")
    return HallCodes(register, pins[:PINS_PER_PHONE])


@contextlib.contextmanager
def profiling(
    pid: int, output: Path | None, *, subprocesses: bool = False, rate: int = 100
) -> Iterator[None]:
    """py-spy sampling the server (``--subprocesses``: its workers too) meanwhile, into
    ``output`` as raw collapsed stacks (what it says goes to ``output`` + ``.log``);
    without an output, nothing."""
    if output is None:
        yield
        return
    executable = py_spy()
    if executable is None:
        raise SystemExit("profiling needs py-spy: pip install py-spy (the dev extra has it)")
    command = [str(executable), "record", "--pid", str(pid), "--format", "raw"]
    # --gil: only the thread holding the GIL, so threads waiting for work or for the
    # GIL are not counted (C code that releases it, as sqlite3 does, is not either)
    command += ["--rate", str(rate), "--gil", "--nonblocking", "--nolineno"]
    command += ["--output", str(output)]
    if subprocesses:
        command.append("--subprocesses")
    with output.with_suffix(".log").open("wb") as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
    try:
        time.sleep(1.0)  # attached
        yield
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(120)
    if not output.exists():
        said = output.with_suffix(".log").read_text()[-2000:]
        raise RuntimeError(f"py-spy wrote no profile:\n{said}")


def cpu_by_step(
    base_url: str,
    codes: HallCodes,
    pids: Sequence[int],
    background_rate: float,
    profiles: Path | None = None,
) -> dict[str, dict[str, Any]]:
    """Each step alone: ``STEP_PHONES`` fresh phones make it one after another (so
    nothing queues), and the server's CPU over them, less the background's, is what
    one such request costs; with ``profiles`` (a directory), where it goes."""
    tls = ssl.create_default_context()
    phones = [
        httpx.Client(
            base_url=base_url,
            verify=tls,
            timeout=REQUEST_TIMEOUT_S,
            headers={"User-Agent": USER_AGENT},
        )
        for _ in range(STEP_PHONES)
    ]
    pin = codes.pins[0]
    csrf: list[str] = []  # per phone, off its quiz form
    progress: list[str] = []  # per phone, where its answer sent it

    def register(browser: httpx.Client, _index: int) -> httpx.Response:
        return browser.get(f"/t/{codes.register}")

    def scan(browser: httpx.Client, _index: int) -> httpx.Response:
        form = browser.get(f"/t/{pin}")
        csrf.append(_CSRF.search(form.text).group(1))  # type: ignore[union-attr]
        return form

    def answer(browser: httpx.Client, index: int) -> httpx.Response:
        answered = browser.post(
            f"/apps/brain/{PHONE_WALL}/pins/{pin}/answer",
            data={"answer": "hippocampus", "csrf": csrf[index]},
        )
        progress.append(answered.headers["location"])
        return answered

    def progress_page(browser: httpx.Client, index: int) -> httpx.Response:
        return browser.get(progress[index])

    def floor(browser: httpx.Client, _index: int) -> httpx.Response:
        return browser.get("/healthz")

    steps = {
        "register": register,
        "scan": scan,
        "answer": answer,
        "progress": progress_page,
        "floor": floor,  # on connections the steps opened, as the scans and answers are
    }
    figures: dict[str, dict[str, Any]] = {}
    try:
        for step, make in steps.items():
            recording = profiles / f"{step}.txt" if profiles is not None else None
            latencies = []
            with profiling(pids[0], recording, rate=STEP_PROFILE_RATE):
                start, cpu = time.perf_counter(), cpu_seconds(pids)
                for index, browser in enumerate(phones):
                    began = time.perf_counter()
                    if make(browser, index).is_error:
                        raise RuntimeError(f"{step} failed when alone")
                    latencies.append((time.perf_counter() - began) * 1000)
                spent = cpu_seconds(pids) - cpu - background_rate * (time.perf_counter() - start)
            cpu_ms = round(max(0.0, spent) / len(phones) * 1000, 2)
            figures[step] = {
                "server_cpu_ms": cpu_ms,
                "p50_ms": round(percentile(latencies, 0.5), 1),
            }
            if recording is not None:
                profile = summarise_profile(recording, cpu_ms, top=10)
                figures[step]["samples_cover_cpu"] = round(
                    profile["samples"] / STEP_PROFILE_RATE / max(spent, 1e-9), 2
                )
                figures[step]["profile"] = profile["by_work"]
    finally:
        for browser in phones:
            browser.close()
    for step in steps:
        figures[step]["floor_multiple"] = round(
            figures[step]["server_cpu_ms"] / max(figures["floor"]["server_cpu_ms"], 1e-3), 1
        )
    return figures


# --- one scenario ----------------------------------------------------------------------


@dataclass(frozen=True)
class Scenario:
    phones: int = 1000
    period_s: float = 60.0
    workers: int = 1
    database_url: str | None = None  # None: SQLite in a temporary directory
    bus: str = "memory"
    redis_url: str = ""
    generators: int = 1  # load-generator processes
    progress_pages: bool = True  # phones follow each answer to their progress page
    profile: Path | None = None  # a py-spy raw (collapsed stacks) profile of the server
    server_cpus: str | None = None  # taskset's list: the server on these cores only

    @property
    def scaled_out(self) -> bool:
        return self.bus == "redis"


# What ``make bench`` runs: one worker on SQLite with the memory bus (a deployment's
# first server), a hall of 300 and of 1000; then the 1000 on PostgreSQL and Redis with
# one worker and with two (skipped, with the reason, where those servers do not answer).
RUNS = (
    Scenario(phones=300),
    Scenario(phones=1000),
    *(
        Scenario(
            phones=1000,
            workers=workers,
            database_url=POSTGRES_URL,
            bus="redis",
            redis_url=REDIS_URL,
        )
        for workers in (1, 2)
    ),
)


def server_env(scenario: Scenario) -> dict[str, str]:
    env = {
        **LIMIT_SETTINGS,
        "TAGWALL_APPLY_LEAD_MS": str(APPLY_LEAD_MS),
        "TAGWALL_WORKERS": str(scenario.workers),
        "TAGWALL_BUS": scenario.bus,
    }
    if scenario.redis_url:
        env["TAGWALL_REDIS_URL"] = scenario.redis_url
        env["TAGWALL_REDIS_PREFIX"] = f"tagwall-bench-{uuid.uuid4().hex[:8]}"
    return env


@contextlib.contextmanager
def hall_server(scenario: Scenario) -> Iterator[tuple[ServerProcess, HallCodes]]:
    """One ``tagwall serve`` of the scenario on a database of its own, the brain atlas on
    the phones' wall; and what its phones scan."""
    from webapp.cli.testing import ServerProcess
    from webapp.database.migrate import upgrade

    with (
        tempfile.TemporaryDirectory(prefix="tagwall-hall-") as scratch,
        bench_database(scenario.database_url, Path(scratch)) as database_url,
    ):
        upgrade(database_url)
        server = ServerProcess(
            var_dir=Path(scratch) / "var",
            database_url=database_url,
            secret=SECRET,
            extra_env=server_env(scenario),
        )
        if scenario.server_cpus is not None:  # the hall: the server on a core of its own
            tagwall = Path(sys.executable).with_name("tagwall")
            server.command = ["taskset", "-c", scenario.server_cpus, str(tagwall), "serve"]
        server.start()
        try:
            with httpx.Client(timeout=120) as client:
                server.change(PHONE_WALL, {"app": "brain"}, client)
            yield server, replace(hall_codes(database_url), follow_answers=scenario.progress_pages)
        finally:
            server.stop()


def start_tiles(
    context: Any, server: ServerProcess, tile_urls: list[str]
) -> tuple[Connection, BaseProcess]:
    """The tiles' process (:func:`tile_process`) once every tile is connected: its pipe
    (send anything to stop it, then receive its figures) and the process."""
    ours, theirs = context.Pipe()
    tiles: BaseProcess = context.Process(
        target=tile_process,
        args=(server.url, tile_urls, server.operator(), theirs),
        daemon=True,
    )
    tiles.start()
    if not ours.poll(120) or ours.recv() != "ready":
        raise RuntimeError("the tiles did not connect")
    return ours, tiles


def measure(scenario: Scenario) -> dict[str, Any]:
    context = multiprocessing.get_context("spawn")
    with hall_server(scenario) as (server, codes):
        asyncio.run(phones_at(server.url, codes, [time.time()] * WARMUP_PHONES))
        tile_urls = [server.tile_url(TILE_WALL, tile, scheme="ws") for tile in TILES]
        tile_pipe, tiles = start_tiles(context, server, tile_urls)
        return _load(scenario, server, codes, context, tile_pipe, tiles)


def _load(
    scenario: Scenario,
    server: Any,
    codes: HallCodes,
    context: Any,
    tile_pipe: Connection,
    tiles: Any,
) -> dict[str, Any]:
    """The idle stream, then the phones; every figure of the scenario."""
    pids = process_tree(server.pid)
    idle_start, idle_cpu = time.time(), cpu_seconds(pids)
    time.sleep(IDLE_S)
    idle_end, background_cpu = time.time(), cpu_seconds(pids) - idle_cpu
    background_rate = background_cpu / (idle_end - idle_start)

    recording = scenario.profile
    with profiling(server.pid, recording, subprocesses=scenario.workers > 1, rate=PROFILE_RATE):
        start = time.time() + 2.0  # the generators' processes start meanwhile
        schedule = arrivals(scenario.phones, scenario.period_s, start)
        generators = []
        for index in range(scenario.generators):
            ours, theirs = context.Pipe()
            process = context.Process(
                target=generator_process,
                args=(server.url, codes, schedule[index :: scenario.generators], theirs),
                daemon=True,
            )
            process.start()
            generators.append((process, ours))
        load_start, load_cpu = time.time(), cpu_seconds(pids)
        machine_busy = machine_busy_seconds()
        results = []
        for process, pipe in generators:
            results.append(pipe.recv())
            process.join()
        load_end = time.time()
        machine_busy = machine_busy_seconds() - machine_busy
        load_cpu = cpu_seconds(pids) - load_cpu
        memory = memory_mb(pids)
    step_profiles = recording.with_name("steps") if recording is not None else None
    if step_profiles is not None:
        step_profiles.mkdir(exist_ok=True)
    alone = cpu_by_step(server.url, codes, pids, background_rate, step_profiles)
    tile_pipe.send("stop")
    tile_result = tile_pipe.recv()
    tiles.join(30)

    samples = [Sample(*s) for result in results for s in result["samples"]]
    lateness = [late for result in results for late in result["lateness"]]
    generator_cpu = sum(result["cpu_s"] for result in results)
    duration = load_end - start  # from the first phone's arrival
    requests = len(samples)
    net_cpu = max(0.0, load_cpu - background_rate * (load_end - load_start))
    events = [Published(**e) for e in tile_result["published"]]
    idle_events = [e for e in events if idle_start <= e.sent_at < idle_end]
    load_events = [e for e in events if start <= e.sent_at < load_end]
    figures: dict[str, Any] = {
        "phones": scenario.phones,
        "period_s": scenario.period_s,
        "workers": scenario.workers,
        "server_processes": len(pids),
        "database": "postgresql" if scenario.database_url else "sqlite",
        "bus": scenario.bus,
        "generators": scenario.generators,
        "server_cpus": scenario.server_cpus,  # None: not pinned
        "progress_pages": scenario.progress_pages,
        # cores kept busy meanwhile by processes other than the server and the load
        # generators (the tiles' process, py-spy, and whatever else shares the machine)
        "other_cores_busy": round(
            (machine_busy - load_cpu - generator_cpu) / (load_end - load_start), 2
        ),
        "requests": requests,
        "failures": sum(s.failed for s in samples),
        "steps": step_figures(samples),
        "load_seconds": round(duration, 1),
        "requests_per_second": round(requests / duration, 1),
        "server_cpu_s": round(load_cpu, 2),
        "server_cpu_background_s_per_s": round(background_rate, 4),
        "server_cpu_ms_per_request": round(net_cpu / requests * 1000, 2),
        "server_cpu_ms_per_phone": round(net_cpu / scenario.phones * 1000, 1),
        "server_cores_busy": round(load_cpu / duration, 2),
        "server_cpu_by_step_alone": alone,
        "server_memory": memory,
        "generator": {
            "cpu_s": round(generator_cpu, 2),
            "cpu_ms_per_request": round(generator_cpu / requests * 1000, 2),
            "cores_busy": round(generator_cpu / duration, 2),
            "arrival_lateness_ms": {
                "p50": round(percentile(lateness, 0.5) * 1000, 1),
                "p99": round(percentile(lateness, 0.99) * 1000, 1),
                "max": round(max(lateness) * 1000, 1),
            },
        },
        "tiles": {
            "connected": len(TILES),
            "dropped": tile_result["dropped"],
            "publish_interval_s": PUBLISH_INTERVAL_S,
            # changes the server refused (status: how many, and the first answer)
            "refused": {
                status: {"count": len(texts), "first": texts[0]}
                for status, texts in tile_result["refused"].items()
            },
            "client_cpu_s": round(tile_result["cpu_s"], 2),
            "idle": tile_figures(idle_events, len(TILES)),
            "under_load": tile_figures(load_events, len(TILES)),
        },
    }
    if recording is not None:
        profile = summarise_profile(recording, figures["server_cpu_ms_per_request"])
        # how much of the server's CPU the samples account for (the rest: C code
        # without the GIL, and samples py-spy missed)
        profile["samples_cover_cpu"] = round(profile["samples"] / PROFILE_RATE / load_cpu, 2)
        figures["profile"] = profile
    return figures


# --- the profile -----------------------------------------------------------------------

# What the server was doing in a sample: walking its stack from the leaf up, the first
# frame that one of these names claims it (for one frame, the first rule in this order).
# So library time counts for the code of ours that called it (SQLAlchemy under
# ``record_answer`` is storing the answer), and what wraps every request (middlewares,
# FastAPI, uvicorn) only for what it does itself: a middleware's ``__call__`` claims a
# sample only as its leaf (``LEAF_ONLY``), and what runs every request (``OUTER``) does
# not claim code of ours below it, which no rule names: that is "other code of ours:
# MODULE". Frames read ``function (path)``, the path from its package (py-spy).
WORK: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("logging", ("(logging/", "(webapp/core/logs.py")),
    (
        "brain: QR symbols encoded to size the pins' clearance "
        "(registry.anchored_code_side_mm from Atlas.declare_tags)",
        ("anchored_code_side_mm",),
    ),
    (
        "brain: placement preview per view (registry.preview: tag queries, TagRecords, digest)",
        ("preview (webapp/tags/registry.py", "preview.<locals>", "_tags_to_place", "_inputs_hash"),
    ),
    ("volume catalog (lists the volume directory)", ("(webapp/volume/catalog.py",)),
    (
        "brain: pins and round per view (declare_tags, pin_points, get_round)",
        ("Atlas.declare_tags", "Atlas.pin_points", "(webapp/apps/brain_atlas/pins.py"),
    ),
    (
        "brain: round guide, made once per layout (codes, views, pins on the wall)",
        ("Atlas.guide", "Atlas._pin_views"),
    ),
    ("brain: answer stored (Quiz.record_answer)", ("record_answer (",)),
    ("brain: quiz queries (progress, rounds)", ("(webapp/quiz/engine.py",)),
    ("scan log and code cache (tags.scanning)", ("(webapp/tags/scanning.py",)),
    ("code and tag lookups (tags.registry)", ("(webapp/tags/registry.py",)),
    ("wall state commits and hub (the tiles' light changes)", ("(webapp/engine/",)),
    ("tile websockets", ("(webapp/server/routes/ws.py", "(websockets/")),
    ("person loading (people.person)", ("(webapp/people/person.py", "get_person (")),
    (
        "templates (Jinja rendering)",
        ("(webapp/web/templating.py", "(jinja2/", "(markupsafe/", ".html)"),
    ),
    ("rate limits", ("(webapp/people/ratelimit.py", "action_allowed (")),
    (
        "session cookie (visitors middleware, itsdangerous)",
        (
            "visitor_of (",
            "_from_cookie",
            "_serializer",
            "cookie_header",
            "send_with_cookie",
            "(itsdangerous/",
        ),
    ),
    ("security headers middleware", ("send_with_headers",)),
    ("client address middleware", ("client_address (", "_address (", "address_of (")),
    ("database sessions (open, commit, close)", ("(webapp/database/",)),
    ("form parsing (python-multipart)", ("(multipart/", "formparsers.py")),
    ("pydantic (models, validation)", ("(pydantic",)),
    ("FastAPI (dependencies, validation, serialisation)", ("(fastapi/",)),
    ("Starlette (routing, requests, responses)", ("(starlette/",)),
    ("uvicorn / httptools / h11 (HTTP parsing, writes)", ("(uvicorn/", "(httptools/", "(h11/")),
    (
        "thread hand-offs (run_blocking: queue, wake-ups, call_soon_threadsafe)",
        ("(anyio/", "(threading.py", "(queue.py"),
    ),
    ("event loop (uvloop in C: sockets, callbacks; asyncio)", ("(asyncio/", "(uvloop/")),
)
LEAF_ONLY = {
    "SessionCookieMiddleware.__call__": "session cookie (visitors middleware, itsdangerous)",
    "SecurityHeadersMiddleware.__call__": "security headers middleware",
    "ClientAddressMiddleware.__call__": "client address middleware",
}
OURS = ("(webapp/", "(tag_service/", "(wall_client/")
# What runs every request: it claims code of ours it calls only when no rule names it.
OUTER = {
    "FastAPI (dependencies, validation, serialisation)",
    "Starlette (routing, requests, responses)",
    "uvicorn / httptools / h11 (HTTP parsing, writes)",
    "thread hand-offs (run_blocking: queue, wake-ups, call_soon_threadsafe)",
    "event loop (uvloop in C: sockets, callbacks; asyncio)",
}


def parse_raw(text: str) -> list[tuple[list[str], int]]:
    """py-spy's raw format: one ``frame;frame;...;leaf COUNT`` line per distinct stack."""
    stacks = []
    for line in text.splitlines():
        stack, _, count = line.rpartition(" ")
        if stack and count.isdigit():
            stacks.append((stack.split(";"), int(count)))
    return stacks


def work_of(frames: Sequence[str]) -> str:
    """What the server was doing in a sample whose stack is ``frames`` (root first)."""
    leaf = frames[-1] if frames else ""
    for wrapper, name in LEAF_ONLY.items():
        if leaf.startswith(wrapper + " ("):
            return name
    mine = None  # the innermost frame of ours that no rule names
    for frame in reversed(frames):
        claimed = next((n for n, markers in WORK if any(m in frame for m in markers)), None)
        if claimed is not None and (mine is None or claimed not in OUTER):
            return claimed
        if claimed is not None:  # what runs every request ran code of ours
            break
        if mine is None and any(m in frame for m in OURS):
            mine = frame
    return f"other code of ours: {_module(mine)}" if mine else "unattributed (partial stacks)"


def _module(frame: str) -> str:
    return frame.rpartition(" (")[2].rstrip(")")


def package_of(frame: str) -> str:
    """The package (or stdlib module) of a frame: the first part of its path."""
    path = frame.rpartition(" (")[2].rstrip(")")
    return path.split("/")[0].removesuffix(".py") or "?"


def summarise_profile(path: Path, cpu_ms_per_request: float, top: int = 15) -> dict[str, Any]:
    """Shares of the samples, and so of a request's CPU: by what the server was doing
    (``WORK``), by the package running (self), and the functions of ours on the stack
    (cumulative)."""
    stacks = parse_raw(path.read_text())
    total = sum(count for _, count in stacks) or 1
    work: Counter[str] = Counter()
    packages: Counter[str] = Counter()
    ours: Counter[str] = Counter()
    for frames, count in stacks:
        work[work_of(frames)] += count
        packages[package_of(frames[-1])] += count
        for frame in {f for f in frames if "(webapp/" in f or "(tag_service/" in f}:
            ours[frame] += count

    def entry(where: str, count: int) -> dict[str, Any]:
        return {
            "where": where,
            "share": round(count / total, 3),
            "ms_per_request": round(count / total * cpu_ms_per_request, 2),
        }

    def shares(counter: Counter[str], whole: bool = True) -> list[dict[str, Any]]:
        """The ``top`` entries, and (when they add up to the whole) the rest as one."""
        entries = [entry(where, count) for where, count in counter.most_common(top)]
        rest = counter.most_common()[top:]
        if whole and rest:
            entries.append(entry(f"the rest ({len(rest)} more)", sum(c for _, c in rest)))
        return entries

    return {
        "samples": total,
        "by_work": shares(work),
        "self_by_package": shares(packages),
        "cumulative_ours": shares(ours, whole=False),
    }


# --- make bench ------------------------------------------------------------------------


def py_spy() -> Path | None:
    """py-spy beside this Python (the dev extra installs it), if it is there."""
    found = Path(sys.executable).with_name("py-spy")
    return found if found.exists() else None


def run() -> dict[str, Any]:
    """``RUNS``; py-spy profiles the server during the first (not saturated, so its
    mix of requests is the hall's own)."""
    runs: list[dict[str, Any]] = []
    profile: dict[str, Any] | None = None
    missing = unreachable(REDIS_URL, POSTGRES_URL)
    with tempfile.TemporaryDirectory() as scratch:
        for index, scenario in enumerate(RUNS):
            if scenario.scaled_out and missing:
                runs.append({"workers": scenario.workers, "skipped": missing})
                continue
            if index == 0 and py_spy():
                scenario = replace(scenario, profile=Path(scratch) / "profile.txt")
            figures = measure(scenario)
            if "profile" in figures:
                profile = {
                    "run": f"{scenario.phones} phones over {scenario.period_s:.0f} s",
                    **figures.pop("profile"),
                }
            runs.append(figures)
    return {
        "limit_settings": LIMIT_SETTINGS,
        "tile_wall": TILE_WALL,
        "phone_wall": PHONE_WALL,
        "pins_per_phone": PINS_PER_PHONE,
        "runs": runs,
        "target_cpu_ms_per_request": TARGET_CPU_MS_PER_REQUEST,
        # where a phone request's CPU goes (py-spy, ``WORK``); details below
        "profile": profile["by_work"] if profile else "py-spy is not installed",
        "profile_details": profile,
    }


def summary(result: dict[str, Any]) -> str:
    lines = []
    for figures in result["runs"]:
        if "skipped" in figures:
            workers = figures["workers"]
            lines.append(f"   {workers} worker(s) on PostgreSQL and Redis: {figures['skipped']}")
            continue
        steps = ", ".join(
            f"{name} {step['p50_ms']}/{step['p99_ms']} ms"
            + (f" ({step['failures']} failed)" if step["failures"] else "")
            for name, step in figures["steps"].items()
        )
        load = figures["tiles"]["under_load"]["last_tile_ms_from_request"] or {}
        pages = "" if figures["progress_pages"] else " (no progress pages)"
        lines.append(
            f"   {figures['phones']} phones/{figures['period_s']:.0f} s{pages}, "
            f"{figures['workers']} worker(s), {figures['database']}, {figures['bus']} bus: "
            f"{steps} (p50/p99); "
            f"server {figures['server_cpu_ms_per_request']} ms CPU/request, "
            f"{figures['server_memory']['rss_mb']} MB; last tile p99 {load.get('p99')} ms"
            + "".join(
                f"; {r['count']} changes refused ({status})"
                for status, r in figures["tiles"]["refused"].items()
            )
        )
        alone = ", ".join(
            f"{name} {step['server_cpu_ms']} ms ({step['floor_multiple']} floors)"
            for name, step in figures["server_cpu_by_step_alone"].items()
        )
        lines.append(f"      each step alone, server CPU: {alone}")
    return "\n".join(lines)


def cpu_list(text: str) -> set[int]:
    """taskset's CPU list (``0``, ``0,2``, ``1-3``) as a set of CPUs."""
    cpus: set[int] = set()
    for part in text.split(","):
        first, _, last = part.partition("-")
        cpus.update(range(int(first), int(last or first) + 1))
    return cpus


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.lecture_hall", description=__doc__)
    parser.add_argument("--phones", type=int, default=1000)
    parser.add_argument("--period", type=float, default=60.0, help="arrival period, s")
    parser.add_argument("--workers", type=int, default=1, help="server processes")
    parser.add_argument(
        "--database-url",
        help="a PostgreSQL server's URL (postgresql+psycopg://postgres@127.0.0.1:5432/postgres): "
        "a fresh database is made on it and dropped; default SQLite in a temporary directory",
    )
    parser.add_argument("--bus", choices=("memory", "redis"), default="memory")
    parser.add_argument("--redis-url", default="")
    parser.add_argument("--generators", type=int, default=1, help="load-generator processes")
    parser.add_argument(
        "--no-progress-pages",
        action="store_true",
        help="phones do not follow an answer's redirect to their progress page",
    )
    parser.add_argument(
        "--profile",
        type=Path,
        help="write py-spy raw stacks of the server here (each step alone: steps/ beside it)",
    )
    parser.add_argument(
        "--server-cpus", help="taskset's CPU list for the server (the issue's hall: 0)"
    )
    parser.add_argument(
        "--load-cpus",
        help="CPU list for this process, the phones' generators and the tiles (the hall: 1)",
    )
    parser.add_argument("--output", type=Path, help="write the JSON figures here too")
    args = parser.parse_args(argv)
    if args.load_cpus:  # the processes started from here inherit it
        os.sched_setaffinity(0, cpu_list(args.load_cpus))
    figures = measure(
        Scenario(
            phones=args.phones,
            period_s=args.period,
            workers=args.workers,
            database_url=args.database_url,
            bus=args.bus,
            redis_url=args.redis_url,
            generators=args.generators,
            progress_pages=not args.no_progress_pages,
            profile=args.profile,
            server_cpus=args.server_cpus,
        )
    )
    text = json.dumps({"limit_settings": LIMIT_SETTINGS, **figures}, indent=2)
    if args.output:
        args.output.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
