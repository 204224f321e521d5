"""A test card for checking a wall's video sync: every frame shows its own number, once
per display, in digits for people and in blocks a program reads off a screenshot.

The card is a grid of ``columns`` x ``rows`` cells, one per display of a grid wall when
its shape is the stage's (the demo wall: 3 x 2 cells, 480 x 180 px). Each cell is five
rows of four blocks: the first four rows carry the frame number's 16 bits, bit ``k`` at
row ``k // 4``, column ``k % 4``, white for 1 and black for 0, the last bit the parity
of the other 15 (a misread block shows as a failed parity, not as another number); the
fifth row is grey with the number in digits. Played across the wall, a photo or a
screenshot of every display at one instant shows the same number on each when the wall
is in step (``tagwall video testcard``; the browser test and ``make bench`` read it).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np

from webapp.apps.video.probe import NoFfprobe

BITS = 16
DATA_BITS = BITS - 1
BLOCK_COLUMNS = 4
BLOCK_ROWS = 5  # four of bits, one of digits
MAX_FRAMES = 1 << DATA_BITS


def make_testcard(
    target: Path,
    seconds: float,
    fps: int = 30,
    columns: int = 3,
    rows: int = 2,
    size: tuple[int, int] = (480, 180),
) -> Path:
    """Write the test card as an MP4 (H.264 and AAC: a beep every second) to ``target``.
    ValueError for a card that cannot count its frames or has odd sides; NoFfprobe
    without ffmpeg."""
    if seconds * fps >= MAX_FRAMES:
        raise ValueError(f"a card counts {MAX_FRAMES} frames at most ({MAX_FRAMES / fps:.0f} s)")
    width, height = size
    if width % 2 or height % 2 or width < 8 * columns or height < 10 * rows:
        raise ValueError(f"{width} x {height} px does not hold {columns} x {rows} cells")
    program = shutil.which("ffmpeg")
    if program is None:
        raise NoFfprobe("ffmpeg is not installed: apt-get install ffmpeg")
    # one pixel per block, drawn by expression, then blown up without smoothing
    bit = f"mod(X,{BLOCK_COLUMNS})+{BLOCK_COLUMNS}*mod(Y,{BLOCK_ROWS})"
    data = "mod(floor(N/pow(2,ld(0))),2)"
    parity = "mod(" + "+".join(f"mod(floor(N/{1 << k}),2)" for k in range(DATA_BITS)) + ",2)"
    blocks = f"st(0,{bit});if(gte(ld(0),{BITS}),128,255*if(lt(ld(0),{DATA_BITS}),{data},{parity}))"
    cell_w, cell_h = width / columns, height / rows
    digits = [
        f"drawtext=font=DejaVu Sans Mono:text=%{{n}}:fontsize={int(cell_h / BLOCK_ROWS * 0.8)}"
        f":fontcolor=black:x={cell_w * c:.1f}+({cell_w:.1f}-tw)/2"
        f":y={cell_h * (r + (BLOCK_ROWS - 1) / BLOCK_ROWS):.1f}+({cell_h / BLOCK_ROWS:.1f}-th)/2"
        for r in range(rows)
        for c in range(columns)
    ]
    filters = ",".join(
        [
            f"geq=lum='{blocks}'",
            f"scale={width}:{height}:flags=neighbor",
            "setsar=1",
            *digits,
            "format=yuv420p",
        ]
    )
    grid = f"{BLOCK_COLUMNS * columns}x{BLOCK_ROWS * rows}"
    subprocess.run(
        [
            program,
            "-y",
            "-hide_banner",
            "-loglevel",
            "error",
            "-f",
            "lavfi",
            "-i",
            # grey from the source on: the grid keeps its size, odd or not (4:2:0 is even)
            f"color=c=black:s={grid}:r={fps}:d={seconds},format=gray",
            "-f",
            "lavfi",
            "-i",
            f"sine=f=440:beep_factor=2:d={seconds}",
            "-vf",
            filters,
            "-c:v",
            "libx264",
            "-preset",
            "veryfast",
            "-crf",
            "18",
            "-g",
            str(2 * fps),
            "-c:a",
            "aac",
            "-b:a",
            "64k",
            "-movflags",
            "+faststart",
            "-shortest",
            str(target),
        ],
        check=True,
        capture_output=True,
    )
    return target


def read_cell(pixels: np.ndarray) -> int | None:
    """The frame number one cell of the card shows, ``pixels`` (height x width x
    channels, 8-bit) being that cell as a screen shows it; None when its blocks do not
    read as a number (not the card, or a block misread)."""
    height, width = pixels.shape[:2]
    luma = pixels[..., :3].mean(axis=-1) if pixels.ndim == 3 else pixels
    value = 0
    parity = 0
    for k in range(BITS):
        row, column = divmod(k, BLOCK_COLUMNS)
        y = int((row + 0.5) * height / BLOCK_ROWS)
        x = int((column + 0.5) * width / BLOCK_COLUMNS)
        patch = luma[
            max(0, y - height // 40) : y + height // 40 + 1,
            max(0, x - width // 40) : x + width // 40 + 1,
        ]
        level = float(patch.mean())
        if 64 < level < 192:  # grey: not a block of the card
            return None
        one = level >= 128
        if k < DATA_BITS:
            value |= int(one) << k
            parity ^= int(one)
        elif int(one) != parity:
            return None
    return value
