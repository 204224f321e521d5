"""Decoding what a camera sees: photos in, payloads out, and a simulated phone camera.

``decode_image`` reads the QR codes in a picture with zbar, ``open_image`` turns
untrusted bytes (an uploaded photo) into a picture or a clear ``NotAnImage``, and
``as_seen_from`` degrades a rendered code the way a phone camera at a given distance
sees it, so tests can check that a code sized by ``tag_service.sizing`` really reads
from the design distance.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageFilter, ImageOps
from pyzbar.pyzbar import ZBarSymbol  # type: ignore[import-untyped]
from pyzbar.pyzbar import decode as zbar_decode

from tag_service.sizing import Camera

MAX_PIXELS = 40_000_000  # phones deliver 12 MP by default, 24 or 48 MP in some modes
# Formats phones upload (Safari converts HEIC to JPEG for accept="image/*"; JPEG covers
# multi-picture MPO files); others, such as EPS (which runs Ghostscript), are never opened.
ACCEPTED_FORMATS = ("JPEG", "PNG", "WEBP", "GIF", "BMP", "TIFF")
SECOND_PASS_SIDE = 1200  # zbar sometimes misses a code in a huge, soft photo
CAMERA_BLUR_PX = 0.6
CAMERA_NOISE_GREY_LEVELS = 6.0
DEFAULT_CAMERA = Camera()


class NotAnImage(ValueError):
    """Bytes that are not a picture we can read (or one too large to open safely)."""


class TooManyPixels(NotAnImage):
    """A picture with more pixels than may be decoded (a decompression bomb, say)."""


@dataclass(frozen=True)
class Decoded:
    """One QR code found in a picture."""

    payload: str
    rect: tuple[int, int, int, int]  # x, y, width, height in the picture's pixels


def decode_image(image: Image.Image) -> list[Decoded]:
    """Every QR code zbar finds in ``image``, top to bottom, then left to right.

    Transparent areas count as white. When a large picture yields nothing, a
    downscaled copy is tried too (rectangles are given in the original's pixels).
    """
    grey = _greyscale(image)
    found = _zbar(grey, 1.0)
    if not found and max(grey.size) > SECOND_PASS_SIDE * 1.5:
        factor = SECOND_PASS_SIDE / max(grey.size)
        size = (max(1, round(grey.width * factor)), max(1, round(grey.height * factor)))
        found = _zbar(grey.resize(size, Image.Resampling.BOX), factor)
    return sorted(found, key=lambda d: (d.rect[1], d.rect[0], d.payload))


def _greyscale(image: Image.Image) -> Image.Image:
    if image.mode in ("RGBA", "LA", "PA") or (image.mode == "P" and "transparency" in image.info):
        rgba = image.convert("RGBA")
        white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
        return Image.alpha_composite(white, rgba).convert("L")
    return image if image.mode == "L" else image.convert("L")


def _zbar(grey: Image.Image, factor: float) -> list[Decoded]:
    found: list[Decoded] = []
    for symbol in zbar_decode(grey, symbols=[ZBarSymbol.QRCODE]):
        data: bytes = symbol.data
        try:
            payload = data.decode("utf-8")
        except UnicodeDecodeError:
            payload = data.decode("latin-1")
        left, top, width, height = (round(v / factor) for v in symbol.rect)
        found.append(Decoded(payload, (left, top, width, height)))
    return found


def open_image(data: bytes, max_pixels: int = MAX_PIXELS) -> Image.Image:
    """The picture in ``data``, upright (EXIF orientation applied) and fully loaded.

    Raises ``NotAnImage`` for anything else: empty, garbage or truncated files and
    formats outside ``ACCEPTED_FORMATS``; ``TooManyPixels`` (a ``NotAnImage``) for
    pictures of more than ``max_pixels``, checked from the header before any pixel
    is decoded. Pillow's own decompression-bomb limit (``Image.MAX_IMAGE_PIXELS``,
    where it only warns) caps ``max_pixels`` too, and its error above twice that
    becomes ``TooManyPixels``. The warnings filters are left alone: they are
    process-wide, and this runs in worker threads.
    """
    if not data:
        raise NotAnImage("the file is empty")
    limit = max_pixels
    if Image.MAX_IMAGE_PIXELS is not None:
        limit = min(limit, Image.MAX_IMAGE_PIXELS)
    Image.init()  # registers every plugin once, so ``formats`` can name them
    formats = [name for name in ACCEPTED_FORMATS if name in Image.OPEN]
    try:
        image = Image.open(io.BytesIO(data), formats=formats)
    except Image.DecompressionBombError as error:
        raise TooManyPixels("the picture has too many pixels to open safely") from error
    except Exception as error:  # untrusted bytes: any decoder failure means "unreadable"
        raise NotAnImage("the file is not a picture that can be read") from error
    width, height = image.size
    if width * height > limit:
        image.close()
        raise TooManyPixels(
            f"the picture is {width}x{height} pixels; at most "
            f"{limit / 1e6:g} million pixels are accepted"
        )
    try:
        with image:
            image.load()
            return ImageOps.exif_transpose(image)
    except Exception as error:  # truncated data, broken EXIF, decoder errors
        raise NotAnImage("the file is not a picture that can be read") from error


def as_seen_from(
    image: Image.Image,
    px_per_module: int,
    module_mm: float,
    distance_m: float,
    camera: Camera = DEFAULT_CAMERA,
    seed: int = 0,
) -> Image.Image:
    """``image`` (a code drawn with ``px_per_module`` pixels per module, each module
    ``module_mm`` wide on the display) as a phone camera ``distance_m`` away sees it.

    Why: sizing promises that a module covers ``camera.px_per_module`` camera pixels at
    the design distance. A crisp rendering proves nothing about that, so this imitates
    the three things a camera does to the code: it samples it onto its own, coarser
    pixel grid (scaled so a module spans ``module_mm / camera.mm_per_camera_px(d)``
    camera pixels, at no particular phase, area-averaged like a sensor), the lens and
    demosaicing soften edges (a Gaussian blur of about 0.6 camera pixels) and the
    sensor adds noise (Gaussian, sigma of 6 grey levels, from a fixed ``seed`` so a
    test gives the same answer every run). The result is a greyscale picture.
    """
    if px_per_module <= 0 or module_mm <= 0:
        raise ValueError("px_per_module and module_mm must be positive")
    camera_px_per_module = module_mm / camera.mm_per_camera_px(distance_m)
    factor = camera_px_per_module / px_per_module
    grey = _greyscale(image)
    size = (max(1, round(grey.width * factor)), max(1, round(grey.height * factor)))
    resample = Image.Resampling.BOX if factor < 1 else Image.Resampling.BILINEAR
    seen = grey.resize(size, resample).filter(ImageFilter.GaussianBlur(CAMERA_BLUR_PX))
    rng = np.random.default_rng(seed)
    pixels = np.asarray(seen, dtype=np.float64)
    noisy = pixels + rng.normal(0.0, CAMERA_NOISE_GREY_LEVELS, pixels.shape)
    return Image.fromarray(np.clip(np.rint(noisy), 0, 255).astype(np.uint8))
