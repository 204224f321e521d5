"""Images the image app's tests make: small, with a pattern a wrong region would break."""

from __future__ import annotations

import json
import struct
import subprocess
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image


def quadrants(width: int, height: int) -> np.ndarray:
    """An RGB image whose red rises left to right, green top to bottom, and blue marks
    the right half: any region's colour says where in the image it lies."""
    x = np.linspace(0, 255, width, dtype=np.float32)[None, :]
    y = np.linspace(0, 255, height, dtype=np.float32)[:, None]
    red = np.broadcast_to(x, (height, width))
    green = np.broadcast_to(y, (height, width))
    blue = np.where(np.arange(width)[None, :] >= width // 2, 220, 30) * np.ones((height, 1))
    return np.stack([red, green, blue], axis=-1).astype(np.uint8)


def save(path: Path, pixels: np.ndarray) -> Path:
    Image.fromarray(pixels).save(path)
    return path


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_declaring(path: Path, width: int, height: int) -> Path:
    """A PNG whose header declares ``width`` x ``height`` (a decompression bomb, or no
    pixels at all) over a few bytes of data."""
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(b"\0" * 1000))
        + _chunk(b"IEND", b"")
    )
    return path


def node_answer(script: str) -> Any:
    """What an ES module ``script`` prints as JSON under Node: the image layer's own
    answers, to hold a Python copy of one of its rules to them."""
    out = subprocess.run(
        ["node", "--input-type=module", "-e", script],
        capture_output=True,
        text=True,
        check=True,
        timeout=30,
    )
    return json.loads(out.stdout)


SVG = (
    b'<?xml version="1.0"?><svg xmlns="http://www.w3.org/2000/svg" width="600" height="400">'
    b'<rect width="600" height="400" fill="red"/></svg>'
)
PDF = (
    b"%PDF-1.4\n1 0 obj<</Type/Catalog/Pages 2 0 R>>endobj\n"
    b"2 0 obj<</Type/Pages/Kids[3 0 R]/Count 1>>endobj\n"
    b"3 0 obj<</Type/Page/Parent 2 0 R/MediaBox[0 0 600 400]>>endobj\n"
    b"trailer<</Root 1 0 R>>\n%%EOF\n"
)
POSTSCRIPT = (
    b"%!PS-Adobe-3.0\n%%BoundingBox: 0 0 600 400\n"
    b"newpath 0 0 moveto 600 0 lineto 600 400 lineto closepath fill showpage\n"
)
FOREIGN = {"drawing.png": SVG, "slides.png": PDF, "poster.png": POSTSCRIPT}
"""Files libvips would decode (through librsvg, poppler, ImageMagick) under a PNG's name."""
