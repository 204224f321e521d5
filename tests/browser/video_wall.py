"""What the video app's browser tests and its benchmark play on and measure with: the
demo wall's six displays with no designated screen, so the stage is all six and the
test card (``tagwall video testcard``: 3 x 2 cells in the stage's shape) shows each
display one whole cell; the card, made once per process; and the two ways of reading
which frame each tile shows: screenshots of all six taken at once, and each tile's
``requestVideoFrameCallback`` against the true clock (``performance.timeOrigin``, never
skewed: the machine's own clock, the server's).

Async Playwright: one screenshot request per tile sent together and answered as each
tile's compositor gets to it (the sync API takes them one after another, 30-90 ms
apart). Each capture's window (sent to answered) is kept: the frames read are compared
knowing how far apart in time the captures can be."""

from __future__ import annotations

import asyncio
import base64
import io
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from playwright.async_api import Browser, CDPSession, Page

from webapp.apps.video.testcard import make_testcard, read_cell
from webapp.cli.testing import ServerProcess, skewed_clock

TILES = ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
SKEWS_MS = [-300, 300, -150, 150, 0, 250]  # each tile's clock, as unsynchronised machines'
FPS = 30
# The demo wall (content/walls/demo.toml) as a lecture hall might set it up for a film:
# its six 55-inch displays, the registration codes left off.
WALL = """
id = "demo"
name = "Demo wall, every display for the film"
bezel_mode = "overlay"
seat_distance_m = 2.0

[grid]
columns = 3
rows = 2
resolution = [1920, 1080]
active_mm = [1209.6, 680.4]
bezel_mm = 3.5
displays_per_node = 6

[screens]
registration = []
"""

_cards: dict[float, Path] = {}
_lock = threading.Lock()


def lecture_wall(folder: Path) -> Path:
    """The wall's config file, written into ``folder``."""
    path = folder / "demo-film.toml"
    path.write_text(WALL)
    return path


def numbered_card(folder: Path, seconds: float) -> Path:
    """The 3 x 2 test card, 480 x 180 px at 30 fps, ``seconds`` long (once a process)."""
    with _lock:
        if seconds not in _cards:
            _cards[seconds] = make_testcard(folder / f"card-{seconds:g}.mp4", seconds, FPS)
        return _cards[seconds]


def show_card(server: ServerProcess, card: Path) -> str:
    """Store ``card`` through the API and show it on the wall, paused; its id."""
    added = server.http.post(
        "/api/apps/video/videos",
        files={"file": (card.name, card.read_bytes(), "video/mp4")},
        headers=server.operator(),
        timeout=60,
    )
    assert added.status_code == 201, added.text
    video: str = added.json()["id"]
    shown = server.http.post(
        "/api/apps/video/walls/demo/show", json={"video": video}, headers=server.operator()
    )
    assert shown.status_code == 200, shown.text
    return video


async def open_tiles(
    browser: Browser, server: ServerProcess
) -> tuple[list[Page], list[CDPSession]]:
    """Each tile in its own context, its clock skewed, a small window (decoding is the
    same; drawing six Full HD canvases 30 times a second is not what is measured)."""
    pages, sessions = [], []
    for tile, skew in zip(TILES, SKEWS_MS, strict=True):
        context = await browser.new_context(viewport={"width": 480, "height": 270})
        await context.add_init_script(skewed_clock(skew))
        page = await context.new_page()
        await page.goto(server.tile_url("demo", tile))
        pages.append(page)
        sessions.append(await context.new_cdp_session(page))
    return pages, sessions


async def marks(pages: list[Page]) -> list[str]:
    """Each tile's ``data-video`` mark: what its video does, in words."""
    return [await page.evaluate("document.body.dataset.video || ''") for page in pages]


RECORD_FRAMES = """() => {
  const video = document.querySelector("video");
  window.__frames = [];
  const record = (now, meta) => {
    window.__frames.push([meta.mediaTime, performance.timeOrigin + meta.expectedDisplayTime]);
    video.requestVideoFrameCallback(record);
  };
  video.requestVideoFrameCallback(record);
}"""


@dataclass
class Capture:
    """One round: the frame each tile showed, and when each capture was asked and had."""

    frames: list[int | None]
    sent: list[float]
    done: list[float]

    @property
    def window_ms(self) -> float:
        """The longest any two captures can be apart: first asked to last answered."""
        return (max(self.done) - min(self.sent)) * 1000

    @property
    def spread(self) -> int:
        numbers = [f for f in self.frames if f is not None]
        return max(numbers) - min(numbers)

    def off(self, clock: dict[str, Any]) -> list[int]:
        """Per tile, how far (in frames) what it showed lies outside what ``clock``
        puts on screen during its own capture's window (0: within it)."""
        off = []
        for frame, sent, done in zip(self.frames, self.sent, self.done, strict=True):
            assert frame is not None
            first, last = (due_frame(clock, at * 1000) for at in (sent, done))
            off.append(max(first - frame, frame - last, 0))
        return off


async def capture(sessions: list[CDPSession]) -> Capture:
    """A screenshot of every tile at once (CDP's Page.captureScreenshot to each together),
    each read for the frame number its display shows."""

    async def one(session: CDPSession) -> tuple[float, float, str]:
        sent = time.time()
        shot = await session.send("Page.captureScreenshot", {"format": "png"})
        return sent, time.time(), shot["data"]

    taken = await asyncio.gather(*(one(s) for s in sessions))
    frames = [
        read_cell(np.asarray(Image.open(io.BytesIO(base64.b64decode(data))).convert("RGB")))
        for _, _, data in taken
    ]
    return Capture(frames, [s for s, _, _ in taken], [d for _, d, _ in taken])


def due_frame(clock: dict[str, Any], at_ms: float) -> int:
    """The frame ``clock`` puts on screen at server (true) time ``at_ms``."""
    return int((clock["media_s"] + (at_ms - clock["wall_ms"]) / 1000) * FPS)


def frame_errors(
    samples: list[list[float]], clock: dict[str, Any], start: float, end: float
) -> list[int]:
    """Per frame a tile presented between server ms ``start`` and ``end``: its number
    less the one ``clock`` puts on screen at that instant (true time)."""
    errors = []
    for media_time, shown_at in samples:
        if start <= shown_at <= end:
            errors.append(round(media_time * FPS) - due_frame(clock, shown_at))
    return errors
