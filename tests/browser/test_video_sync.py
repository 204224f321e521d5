"""Video in step on every tile (issue 41): the frame-numbered test card plays on the demo
wall's six tiles, their clocks skewed as unsynchronised machines' are; which frame each
shows is read from screenshots of all six taken at once, and from each tile's
``requestVideoFrameCallback`` media time against the true clock, over a stretch of
playback, after a seek while playing, and paused.

The bounds hold on a loaded two-core machine (six tiles decoding and drawing beside the
server): they prove the mechanism. How close the tiles stay over 60 s is measured by
``make bench`` (benchmarks/video_sync.py), with the same readers (video_wall.py).
"""

from __future__ import annotations

import asyncio
import shutil
import statistics
import time
from collections.abc import Awaitable, Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from playwright.async_api import CDPSession, async_playwright

from tests.browser.conftest import ONE_INSTANT_MS, serve
from tests.browser.video_wall import (
    FPS,
    RECORD_FRAMES,
    TILES,
    Capture,
    capture,
    frame_errors,
    lecture_wall,
    marks,
    numbered_card,
    open_tiles,
    show_card,
)
from webapp.cli.testing import CHROMIUM_ARGS, ServerProcess

pytestmark = pytest.mark.alone  # six tiles decoding video: nothing else on the machine

CARD_S = 60.0
SETTLE_S = 2.5  # a start or a seek settles (a seek ahead, then the rate steers) in this
ROUNDS = 8  # simultaneous captures per stretch, ROUND_GAP_S apart
ROUND_GAP_S = 0.6

# The bounds. On an idle machine every frame a tile presents is within one frame (33 ms)
# of the one the wall clock puts on screen. The suite shares two cores with other work,
# up to five times as much as they hold: a starved tile presents a frame late now and
# then, and its clock estimate (ping round trips) wanders by a frame or two. Held here:
# most frames within one, the middle one within one, nearly all within the suite's one
# instant (static/js tiles showing a change: 200 ms, tests/browser/conftest.py). A wall
# whose clocks were not followed (the tiles' skews, up to 300 ms) or whose seek or start
# landed anywhere else is nine frames and more off throughout, and fails all three.
WITHIN_ONE_SHARE = 0.5
MEDIAN_ABS_MAX = 1
NEARLY_ALL = 0.95
ONE_INSTANT_FRAMES = round(ONE_INSTANT_MS * FPS / 1000)


async def rounds(sessions: list[CDPSession]) -> list[Capture]:
    taken = []
    for _ in range(ROUNDS):
        taken.append(await capture(sessions))
        await asyncio.sleep(ROUND_GAP_S)
    return taken


def summary(errors: list[int]) -> dict[str, float]:
    """How far off a tile's frames were: the share within one frame, the middle one's
    distance, the share within one instant, the worst."""
    distances = sorted(abs(e) for e in errors)
    return {
        "frames": len(errors),
        "within_one": round(sum(d <= 1 for d in distances) / len(distances), 3),
        "median_abs": statistics.median(distances),
        "within_instant": round(
            sum(d <= ONE_INSTANT_FRAMES for d in distances) / len(distances), 3
        ),
        "worst": max(errors, key=abs),
    }


def bounded(measured: dict[str, float]) -> bool:
    return (
        measured["within_one"] >= WITHIN_ONE_SHARE
        and measured["median_abs"] <= MEDIAN_ABS_MAX
        and measured["within_instant"] >= NEARLY_ALL
    )


@pytest.fixture
def film(tmp_path: Path, database_url: str) -> Iterator[ServerProcess]:
    """A server on the six-display demo wall with the test card shown, paused."""
    server = serve(tmp_path, database_url, TAGWALL_WALL_CONFIGS=str(lecture_wall(tmp_path)))
    try:
        show_card(server, numbered_card(tmp_path, CARD_S))
        yield server
    finally:
        server.stop()


async def until(condition: Callable[[], Awaitable[bool]], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not await condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out waiting for {what}")
        await asyncio.sleep(0.1)


async def test_six_tiles_show_the_same_frame_playing_after_a_seek_and_paused(
    film: ServerProcess, tmp_path: Path
) -> None:
    server = film
    operator = server.operator()

    def step(path: str, **body: object) -> dict[str, Any]:
        answer = server.http.post(
            f"/api/apps/video/walls/demo/{path}", json=body or None, headers=operator
        )
        assert answer.status_code == 200, answer.text
        result: dict[str, Any] = answer.json()
        return result

    async with async_playwright() as playwright:
        browser = await playwright.chromium.launch(
            executable_path=shutil.which("chromium"), args=CHROMIUM_ARGS
        )
        pages, sessions = await open_tiles(browser, server)

        async def loaded() -> bool:
            return all(mark.startswith("paused") for mark in await marks(pages))

        await until(loaded, 60, "every tile to load the video")
        for page in pages:
            await page.evaluate(RECORD_FRAMES)
        paused_at_start = await capture(sessions)
        assert paused_at_start.frames == [0] * len(TILES), paused_at_start

        played = step("play")["clock"]
        await asyncio.sleep((played["wall_ms"] / 1000 - time.time()) + SETTLE_S)
        playing = await rounds(sessions)
        stretch = (played["wall_ms"] + SETTLE_S * 1000, time.time() * 1000)

        sought = step("seek", to_s=40.0)["clock"]
        await asyncio.sleep((sought["wall_ms"] / 1000 - time.time()) + SETTLE_S)
        after_seek = await rounds(sessions)
        since_seek = (sought["wall_ms"] + SETTLE_S * 1000, time.time() * 1000)

        stopped = step("pause")["clock"]
        await asyncio.sleep((stopped["wall_ms"] / 1000 - time.time()) + 1.0)
        paused = await capture(sessions)
        samples = [await page.evaluate("window.__frames") for page in pages]
        said = await marks(pages)
        for index, page in enumerate(pages):  # at native size, to look at
            await page.set_viewport_size({"width": 1920, "height": 1080})
            await page.screenshot(path=tmp_path / f"paused-{TILES[index]}.png")
        await browser.close()

    # what was measured, all of it, before any bound is held to it
    taken = playing + after_seek
    print(f"\ncapture windows (ms): {[round(c.window_ms, 1) for c in taken]}")
    print(f"frames read: {[c.frames for c in taken]}; paused: {paused.frames}")
    measured = {}
    for tile, frames, clock_said in zip(TILES, samples, said, strict=True):
        measured[tile] = (
            summary(frame_errors(frames, played, *stretch)),
            summary(frame_errors(frames, sought, *since_seek)),
        )
        print(f"{tile}: playing {measured[tile][0]}, after the seek {measured[tile][1]}; "
              f"{clock_said}")  # fmt: skip

    # paused: every tile on the very frame the statement names
    due = int(stopped["media_s"] * FPS)  # the frame that holds that instant
    assert paused.frames == [paused.frames[0]] * len(TILES), paused
    assert abs(paused.frames[0] - due) <= 1, (paused.frames, stopped)  # float rounding

    # screenshots taken together: how far each tile's frame lay outside what the wall
    # clock put on screen while its own capture was under way
    assert all(None not in c.frames for c in taken), taken
    off = [d for c in playing for d in c.off(played)]
    off += [d for c in after_seek for d in c.off(sought)]
    shots = summary(off)
    print(f"screenshots: {shots}; the six's spread: {[c.spread for c in taken]} frames")
    assert bounded(shots), shots
    assert after_seek[0].frames[0] >= 40 * FPS

    # each tile's own frames against the true clock
    for tile, stretches in measured.items():
        for errors in stretches:
            assert errors["frames"] > 0.8 * FPS * ROUNDS * ROUND_GAP_S, (tile, errors)
            assert bounded(errors), (tile, errors)
