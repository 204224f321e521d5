"""Memory: what a connected tile and an active phone session cost the server, and
whether its memory stays bounded while phones come and go.

One ``tagwall serve`` (SQLite, the memory bus, one process), set up as the lecture hall
sets it up (:func:`benchmarks.lecture_hall.hall_server`: the brain atlas on the
``demo`` wall, the limits per address lifted), is measured by its resident memory
(:func:`benchmarks.measuring.memory_kb`: all of it, and its anonymous part, where a
leak grows). Everything runs on loopback, the clients in processes of their own.

1. Warm-up: ``WARMUP_PHONES`` phones and every tile of the ``hiperwall`` connected
   for ``WARMUP_TILES_S`` while light changes go out, so what is loaded once (the
   atlas, templates, worker threads) is in the baseline.
2. Per tile: ``TILE_SOCKETS`` tile websockets (the lecture hall's tiles, several per
   tile of the ``hiperwall``) say hello and receive their snapshot, then the light
   changes published every half second reach them for ``SETTLE_S``;
   (after - before) / sockets.
3. Per phone session: ``SESSION_PHONES`` of the lecture hall's phones, arriving
   ``SESSION_PHONES_PER_S`` a second (each scans the registration code, then three
   pins, answers each and follows to its progress page), then ``SETTLE_S``;
   (after - before) / phones.
4. Soak: for ``SOAK_S`` new phones keep coming, ``SOAK_PHONES_PER_S`` a second, each
   leaving after its visit; the tiles stay and the light changes go on, while
   ``CHURN_TILES`` more tile sockets leave and reconnect every ``CHURN_HOLD_S``.
   Memory is sampled every ``SAMPLE_INTERVAL_S``. The first half brings the server to
   its steady state (pools, allocator arenas, caches filled to their bounds); over the
   second half, the least-squares slope in MB a minute, with its standard error.

Growth is bounded unless the slope, less twice its standard error (the noise of the
samples), passes what ``GROWTH_KB_PER_PHONE`` per phone that came would make: about
what the least the server could keep per visitor for good costs (a visitor id in a
set). A leak smaller than that, or one that the allocator's free memory still absorbs
(tens of MB once warm), does not show in ten minutes of resident memory: the
structures below are bounded by reading them, not by this soak.

What the server keeps per phone in memory, and what bounds it: the abuse limits'
sliding window of the phone's scans (``MemoryCounters``, a key per visitor, forgotten
once its hits are out of the window), scans queued for at most a batch's interval
(``ScanLog``); per code, not per phone, the scan path's code cache (``CodeDirectory``,
``max_codes``, 2 s each); per layout of a wall, the brain's round guides
(``SizedCache``). Sessions are signed cookies and people rows in the database.

``python -m benchmarks.memory --soak-seconds 60 --phones 100 --tiles 50`` runs a short
one and prints it (``--help``: the options).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import multiprocessing
import sys
import time
from collections.abc import Sequence
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any

from benchmarks.lecture_hall import (
    LIMIT_SETTINGS,
    PHONE_WALL,
    PINS_PER_PHONE,
    TILE_WALL,
    TILES,
    HallCodes,
    Published,
    Sample,
    Scenario,
    arrivals,
    generator_process,
    hall_server,
    start_tiles,
    step_figures,
    tile_figures,
)
from benchmarks.measuring import memory_kb, percentile, process_tree, told_to_stop

WARMUP_PHONES = 100
WARMUP_TILES_S = 3.0
TILE_SOCKETS = 200
SESSION_PHONES = 1000
SESSION_PHONES_PER_S = 20.0
SETTLE_S = 5.0
SOAK_S = 600.0
SOAK_PHONES_PER_S = 10.0
CHURN_TILES = 20
CHURN_HOLD_S = 30.0
SAMPLE_INTERVAL_S = 10.0
GROWTH_KB_PER_PHONE = 0.1
START_S = 2.0  # the phones' process starts before the first arrives


# --- pure parts ------------------------------------------------------------------------


def trend(points: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """The least-squares slope of ``(x, y)`` points and its standard error (0 with
    fewer than three points, where it cannot be told)."""
    count = len(points)
    if count < 2:
        raise ValueError("a slope needs two points")
    mean_x = sum(x for x, _ in points) / count
    mean_y = sum(y for _, y in points) / count
    spread = sum((x - mean_x) ** 2 for x, _ in points)
    slope = sum((x - mean_x) * (y - mean_y) for x, y in points) / spread
    if count < 3:
        return slope, 0.0
    residuals = sum((y - mean_y - slope * (x - mean_x)) ** 2 for x, y in points)
    return slope, math.sqrt(residuals / (count - 2) / spread)


def growth_limit_mb_per_min(phones_per_s: float) -> float:
    """What ``GROWTH_KB_PER_PHONE`` makes in a minute of ``phones_per_s``."""
    return GROWTH_KB_PER_PHONE * phones_per_s * 60 / 1024


def bounded(slope: float, error: float, limit: float) -> bool:
    """Whether a slope is within the limit, give or take twice its standard error."""
    return slope - 2 * error <= limit


def per_item_kb(before: dict[str, int], after: dict[str, int], items: int) -> dict[str, float]:
    """What each of ``items`` added to the resident memory and to its anonymous part."""
    return {name: round((after[name] - before[name]) / items, 2) for name in ("rss", "anon")}


def megabytes(memory: dict[str, int]) -> dict[str, float]:
    return {f"{name}_mb": round(kb / 1024, 1) for name, kb in memory.items()}


# --- tiles that come and go ------------------------------------------------------------


def churn_process(tile_urls: list[str], hold_s: float, pipe: Connection) -> None:
    asyncio.run(churning_tiles(tile_urls, hold_s, pipe))


async def churning_tiles(tile_urls: list[str], hold_s: float, pipe: Connection) -> None:
    """Each tile connects, says hello, receives its snapshot, reads what comes for
    ``hold_s``, leaves and connects again; their visits spread evenly over ``hold_s``.
    Until told to stop; then reports the visits, and those that failed (no snapshot, or
    closed by the server)."""
    from websockets.asyncio.client import connect
    from websockets.exceptions import WebSocketException

    stop = told_to_stop(pipe)
    visits = failures = 0

    async def stay(socket: Any) -> bool:
        """Read for ``hold_s`` or until told to stop; False when the server closed first."""
        reading = asyncio.ensure_future(_read_all(socket))
        stopping = asyncio.ensure_future(stop.wait())
        await asyncio.wait({reading, stopping}, timeout=hold_s, return_when=asyncio.FIRST_COMPLETED)
        closed = reading.done()
        for task in (reading, stopping):
            task.cancel()
        return not closed

    async def tile(url: str, offset_s: float) -> None:
        nonlocal visits, failures
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(stop.wait(), offset_s)
        while not stop.is_set():
            visits += 1
            try:
                async with connect(url, max_size=2**22) as socket:
                    await socket.send(json.dumps({"type": "hello", "last_version": None}))
                    snapshot = json.loads(await socket.recv())
                    if snapshot["type"] != "snapshot" or not await stay(socket):
                        failures += 1
            except (OSError, WebSocketException):
                failures += 1
                await asyncio.sleep(1.0)

    count = len(tile_urls)
    await asyncio.gather(*(tile(url, hold_s * i / count) for i, url in enumerate(tile_urls)))
    pipe.recv()
    pipe.send({"visits": visits, "failures": failures})


async def _read_all(socket: Any) -> None:
    """Until the server closes the socket (cleanly or not)."""
    from websockets.exceptions import WebSocketException

    with contextlib.suppress(WebSocketException):
        async for _ in socket:
            pass


# --- phones ----------------------------------------------------------------------------


def start_phones(
    context: Any, base_url: str, codes: HallCodes, schedule: list[float]
) -> tuple[Connection, BaseProcess]:
    """The lecture hall's phones of ``schedule`` in a process of their own."""
    ours, theirs = context.Pipe()
    process: BaseProcess = context.Process(
        target=generator_process, args=(base_url, codes, schedule, theirs), daemon=True
    )
    process.start()
    return ours, process


def phone_figures(result: dict[str, Any]) -> dict[str, Any]:
    """Failures (a status not 2xx/3xx, or no answer) and latency per step; how late
    the phones started against their schedule (whether the generator kept up)."""
    samples = [Sample(*s) for s in result["samples"]]
    return {
        "requests": len(samples),
        "failures": sum(s.failed for s in samples),
        "steps": step_figures(samples),
        "arrival_lateness_ms_p99": round(percentile(result["lateness"], 0.99) * 1000, 1),
        "generator_cpu_s": round(result["cpu_s"], 1),
    }


def finish(pipe: Connection, process: BaseProcess) -> Any:
    result = pipe.recv()
    process.join(30)
    return result


# --- the run ---------------------------------------------------------------------------


def measure(
    *,
    tiles: int = TILE_SOCKETS,
    phones: int = SESSION_PHONES,
    soak_s: float = SOAK_S,
    soak_phones_per_s: float = SOAK_PHONES_PER_S,
    sample_interval_s: float = SAMPLE_INTERVAL_S,
) -> dict[str, Any]:
    context = multiprocessing.get_context("spawn")
    with hall_server(Scenario()) as (server, codes):
        pids = process_tree(server.pid)
        every_tile = [server.tile_url(TILE_WALL, tile, scheme="ws") for tile in TILES]

        # 1. warm-up
        pipe, process = start_phones(context, server.url, codes, _from_now(WARMUP_PHONES, 10.0))
        finish(pipe, process)
        pipe, process = start_tiles(context, server, every_tile)
        time.sleep(WARMUP_TILES_S)
        pipe.send("stop")
        finish(pipe, process)
        time.sleep(SETTLE_S)
        warm = memory_kb(pids)

        # 2. per tile: these stay connected, and the light changes go on, to the end
        tile_urls = [every_tile[i % len(every_tile)] for i in range(tiles)]
        tile_pipe, tile_process = start_tiles(context, server, tile_urls)
        time.sleep(SETTLE_S)
        tiled = memory_kb(pids)

        # 3. per phone session
        pipe, process = start_phones(
            context, server.url, codes, _from_now(phones, phones / SESSION_PHONES_PER_S)
        )
        session_phones = phone_figures(finish(pipe, process))
        time.sleep(SETTLE_S)
        phoned = memory_kb(pids)

        # 4. the soak
        churn_pipe, churn = _start_churn(context, every_tile[:CHURN_TILES])
        schedule = _from_now(round(soak_s * soak_phones_per_s), soak_s)
        pipe, process = start_phones(context, server.url, codes, schedule)
        samples = _sample(pids, schedule[0], soak_s, sample_interval_s)
        soak_phones = phone_figures(finish(pipe, process))
        churn_pipe.send("stop")
        churned = finish(churn_pipe, churn)
        tile_pipe.send("stop")
        tile_result = finish(tile_pipe, tile_process)

    events = [Published(**e) for e in tile_result["published"]]
    second_half = [s for s in samples if s["t_s"] >= soak_s / 2]
    limit = growth_limit_mb_per_min(soak_phones_per_s)
    slopes = {}
    for name in ("rss", "anon"):
        slope, error = trend([(s["t_s"] / 60, s[f"{name}_mb"]) for s in second_half])
        slopes[name] = {"mb_per_min": round(slope, 3), "stderr_mb_per_min": round(error, 3)}
    rss_slope, rss_error = slopes["rss"]["mb_per_min"], slopes["rss"]["stderr_mb_per_min"]
    return {
        "limit_settings": LIMIT_SETTINGS,
        "database": "sqlite",
        "bus": "memory",
        "tile_wall": TILE_WALL,
        "phone_wall": PHONE_WALL,
        "pins_per_phone": PINS_PER_PHONE,
        "warm": megabytes(warm),
        "per_tile": {
            "sockets": tiles,
            "before": megabytes(warm),
            "after": megabytes(tiled),
            "kb_per_tile": per_item_kb(warm, tiled, tiles),
        },
        "per_phone": {
            "phones": phones,
            "phones_per_second": SESSION_PHONES_PER_S,
            "before": megabytes(tiled),
            "after": megabytes(phoned),
            "kb_per_phone": per_item_kb(tiled, phoned, phones),
            **session_phones,
        },
        "soak": {
            "seconds": soak_s,
            "phones": len(schedule),
            "phones_per_second": soak_phones_per_s,
            "tiles_connected": tiles,
            "churn": {"tiles": CHURN_TILES, "hold_s": CHURN_HOLD_S, **churned},
            "tiles_dropped": tile_result["dropped"],
            "light_changes": tile_figures(events, tiles),
            "sample_interval_s": sample_interval_s,
            "samples": samples,
            "second_half": {
                "from": second_half[0],
                "to": second_half[-1],
                "slope": slopes,
            },
            "growth_limit_kb_per_phone": GROWTH_KB_PER_PHONE,
            "growth_limit_mb_per_min": round(limit, 3),
            "growth_kb_per_phone": round(
                slopes["rss"]["mb_per_min"] * 1024 / (soak_phones_per_s * 60), 3
            ),
            "bounded": bounded(rss_slope, rss_error, limit),
            **soak_phones,
        },
    }


def _from_now(phones: int, period_s: float) -> list[float]:
    return arrivals(phones, period_s, time.time() + START_S)


def _start_churn(context: Any, tile_urls: list[str]) -> tuple[Connection, BaseProcess]:
    ours, theirs = context.Pipe()
    process: BaseProcess = context.Process(
        target=churn_process, args=(tile_urls, CHURN_HOLD_S, theirs), daemon=True
    )
    process.start()
    return ours, process


def _sample(
    pids: Sequence[int], start: float, seconds: float, interval_s: float
) -> list[dict[str, float]]:
    """The server's memory every ``interval_s`` from ``start`` for ``seconds``."""
    samples = []
    for index in range(int(seconds // interval_s) + 1):
        time.sleep(max(0.0, start + index * interval_s - time.time()))
        memory = megabytes(memory_kb(pids))
        samples.append(
            {
                "t_s": round(time.time() - start, 1),
                "rss_mb": memory["rss_mb"],
                "anon_mb": memory["anon_mb"],
            }
        )
    return samples


# --- make bench ------------------------------------------------------------------------


def run() -> dict[str, Any]:
    return measure()


def summary(result: dict[str, Any]) -> str:
    soak = result["soak"]
    half = soak["second_half"]
    slope = half["slope"]["rss"]
    verdict = "bounded" if soak["bounded"] else "GROWING"
    failures = result["per_phone"]["failures"] + soak["failures"]
    return "\n".join(
        (
            f"   per tile: {result['per_tile']['kb_per_tile']['rss']} kB "
            f"({result['per_tile']['sockets']} sockets); per phone session: "
            f"{result['per_phone']['kb_per_phone']['rss']} kB "
            f"({result['per_phone']['phones']} phones); server {result['warm']['rss_mb']} MB "
            "warm",
            f"   soak {soak['seconds']:.0f} s, {soak['phones']} phones, "
            f"{soak['tiles_connected']} tiles: second half {half['from']['rss_mb']} -> "
            f"{half['to']['rss_mb']} MB, {slope['mb_per_min']} "
            f"± {slope['stderr_mb_per_min']} MB/min (limit {soak['growth_limit_mb_per_min']}): "
            f"{verdict}; {failures} failed requests",
        )
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.memory", description=__doc__)
    parser.add_argument("--tiles", type=int, default=TILE_SOCKETS, help="tile sockets")
    parser.add_argument("--phones", type=int, default=SESSION_PHONES, help="session phones")
    parser.add_argument("--soak-seconds", type=float, default=SOAK_S)
    parser.add_argument(
        "--soak-rate", type=float, default=SOAK_PHONES_PER_S, help="new phones a second"
    )
    parser.add_argument("--sample-interval", type=float, default=SAMPLE_INTERVAL_S, help="s")
    args = parser.parse_args(argv)
    result = measure(
        tiles=args.tiles,
        phones=args.phones,
        soak_s=args.soak_seconds,
        soak_phones_per_s=args.soak_rate,
        sample_interval_s=args.sample_interval,
    )
    print(json.dumps(result, indent=2))
    print(summary(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
