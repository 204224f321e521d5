"""Decoding what a camera sees: photos in, payloads out, and a simulated phone camera.

``decode_image`` reads the QR codes in a picture with zbar, ``open_image`` turns
untrusted bytes (an uploaded photo) into a picture or a clear ``NotAnImage``, and
``as_seen_from`` degrades a rendered code the way a phone camera at a given distance
sees it, so tests can check that a code sized by ``tag_service.sizing`` really reads
from the design distance. ``symbol_damage`` compares a screenshot's pixels with the
symbol a code should show there, module by module: a code can still decode with
something drawn over it, and be the first to fail from a few steps back.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageFilter, ImageOps
from pyzbar.pyzbar import ZBarSymbol  # type: ignore[import-untyped]
from pyzbar.pyzbar import decode as zbar_decode

from tag_service.sizing import Camera
from wall_client.layout import Affine

Ints = npt.NDArray[np.int64]
MAX_PIXELS = 40_000_000  # phones deliver 12 MP by default, 24 or 48 MP in some modes
# Formats phones upload (Safari converts HEIC to JPEG for accept="image/*"; JPEG covers
# multi-picture MPO files); others, such as EPS (which runs Ghostscript), are never opened.
ACCEPTED_FORMATS = ("JPEG", "PNG", "WEBP", "GIF", "BMP", "TIFF")
SECOND_PASS_SIDE = 1200  # zbar sometimes misses a code in a huge, soft photo
DEFAULT_CAMERA = Camera()
MAX_TILT_DEG = 30.0  # people stand off to the side, or hold the phone below the code
SURROUND_GREY = 20  # a display's dark surround, beyond the picture given
OFF_BY = 64  # grey levels a pixel may stray from its module's black or white (a faint fringe)


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


@dataclass(frozen=True)
class Shot:
    """How a phone is held for one frame of a code on a display.

    ``tilt_deg`` is the angle between the camera's line of sight and the display's
    normal (people rarely stand square to a code), in the direction ``tilt_towards_deg``
    (0: from the right, 90: from above); ``roll_deg`` turns the phone about its line of
    sight; ``aim_mm`` is where on the display the camera points, relative to the code's
    centre (the code lands off the frame's centre). Blur (lens, focus, a steady hand),
    sensor noise and JPEG compression are what a phone's pipeline adds; ``contrast``
    is the share of the grey range between the display's white and its black as the
    camera exposes them (a lit room, glare, a display's grey black).
    """

    distance_m: float
    tilt_deg: float = 0.0
    tilt_towards_deg: float = 0.0
    roll_deg: float = 0.0
    aim_mm: tuple[float, float] = (0.0, 0.0)
    blur_px: float = 0.8
    noise_grey_levels: float = 4.0
    jpeg_quality: int = 85
    contrast: float = 0.75


def random_shots(
    distance_m: float, count: int, seed: int, max_tilt_deg: float = MAX_TILT_DEG
) -> list[Shot]:
    """``count`` shots a phone takes from ``distance_m``, drawn from a fixed ``seed``:
    tilts up to ``max_tilt_deg`` in any direction, a phone held within 20 degrees of
    upright, the code within the middle third of the frame, blur between 0.6 and 1.2
    camera pixels, noise of 2 to 6 grey levels, JPEG quality 70 to 90, contrast 0.6 to
    0.9."""
    rng = np.random.default_rng(seed)
    half_field = distance_m * 1000 * math.tan(math.radians(DEFAULT_CAMERA.field_of_view_deg) / 2)
    return [
        Shot(
            distance_m=distance_m,
            tilt_deg=float(max_tilt_deg * math.sqrt(rng.uniform())),
            tilt_towards_deg=float(rng.uniform(0, 360)),
            roll_deg=float(rng.uniform(-20, 20)),
            aim_mm=(
                float(rng.uniform(-1, 1) * half_field / 3),
                float(rng.uniform(-1, 1) * half_field / 3 * 9 / 16),
            ),
            blur_px=float(rng.uniform(0.6, 1.2)),
            noise_grey_levels=float(rng.uniform(2, 6)),
            jpeg_quality=int(rng.integers(70, 91)),
            contrast=float(rng.uniform(0.6, 0.9)),
        )
        for _ in range(count)
    ]


def phone_frame(
    screen: Image.Image,
    mm_per_px: float,
    center_px: tuple[float, float],
    shot: Shot,
    camera: Camera = DEFAULT_CAMERA,
    seed: int = 0,
) -> Image.Image:
    """The frame a phone camera takes of ``screen`` (a display's picture, ``mm_per_px``
    its pixel pitch) when it looks at the point ``center_px`` of it as ``shot`` says:
    a full ``camera.frame_px`` x 9/16 greyscale frame, as barcode readers analyse.

    A pinhole camera with the camera's field of view stands ``shot.distance_m`` from
    that point along the tilted line of sight; every frame pixel sees the display
    point its ray meets (a perspective map, computed at three samples per pixel and
    area-averaged like a sensor), outside the picture the display's dark surround.
    Then contrast, blur, noise (from ``seed``) and JPEG, in the order a phone applies
    them. Sizing promises that at the design distance, square on, a module covers
    ``camera.px_per_module`` frame pixels; this is the test of that promise.
    """
    width = camera.frame_px
    height = round(width * 9 / 16)
    homography = _frame_to_screen(screen.size, mm_per_px, center_px, shot, camera, (width, height))
    frame = Image.new("L", (width, height), SURROUND_GREY)
    # Only the part of the frame the picture covers is computed (the rest is surround).
    sw, sh = screen.size
    corners = np.linalg.inv(homography) @ np.array([[0, sw, 0, sw], [0, 0, sh, sh], [1, 1, 1, 1]])
    us, vs = corners[0] / corners[2], corners[1] / corners[2]
    x0, y0 = max(0, math.floor(us.min()) - 2), max(0, math.floor(vs.min()) - 2)
    x1, y1 = min(width, math.ceil(us.max()) + 2), min(height, math.ceil(vs.max()) + 2)
    if x1 > x0 and y1 > y0:
        supersample = 3
        to_crop = np.array(
            [[1 / supersample, 0, x0], [0, 1 / supersample, y0], [0, 0, 1]], dtype=np.float64
        )
        a, b, c, d, e, f, g, h, i = (homography @ to_crop).ravel()
        fine = _greyscale(screen).transform(
            ((x1 - x0) * supersample, (y1 - y0) * supersample),
            Image.Transform.PERSPECTIVE,
            (a / i, b / i, c / i, d / i, e / i, f / i, g / i, h / i),
            Image.Resampling.BILINEAR,
            fillcolor=SURROUND_GREY,
        )
        frame.paste(fine.resize((x1 - x0, y1 - y0), Image.Resampling.BOX), (x0, y0))
    low = 255 * (1 - shot.contrast) / 2
    pixels = low + np.asarray(frame, dtype=np.float64) * shot.contrast
    blurred = Image.fromarray(np.clip(np.rint(pixels), 0, 255).astype(np.uint8)).filter(
        ImageFilter.GaussianBlur(shot.blur_px)
    )
    rng = np.random.default_rng(seed)
    noisy = np.asarray(blurred, dtype=np.float64) + rng.normal(
        0.0, shot.noise_grey_levels, (height, width)
    )
    buffer = io.BytesIO()
    Image.fromarray(np.clip(np.rint(noisy), 0, 255).astype(np.uint8)).save(
        buffer, "JPEG", quality=shot.jpeg_quality
    )
    buffer.seek(0)
    return Image.open(buffer).convert("L")


def _frame_to_screen(
    screen_size: tuple[int, int],
    mm_per_px: float,
    center_px: tuple[float, float],
    shot: Shot,
    camera: Camera,
    frame_size: tuple[int, int],
) -> npt.NDArray[np.float64]:
    """The homography from frame pixels to screen pixels (3x3, acting on ``(u, v, 1)``).

    World: the display in the plane z = 0, x right and y down in mm, z towards the
    viewer; the code's centre at the origin.
    """
    tilt, towards = math.radians(shot.tilt_deg), math.radians(shot.tilt_towards_deg)
    away = np.array(
        [
            math.sin(tilt) * math.cos(towards),
            -math.sin(tilt) * math.sin(towards),
            math.cos(tilt),
        ]
    )
    position = away * shot.distance_m * 1000
    aim = np.array([shot.aim_mm[0], shot.aim_mm[1], 0.0])
    forward = aim - position
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    down = np.cross(right, forward)
    roll = math.radians(shot.roll_deg)
    right, down = (
        right * math.cos(roll) + down * math.sin(roll),
        -right * math.sin(roll) + down * math.cos(roll),
    )
    width, height = frame_size
    focal = (width / 2) / math.tan(math.radians(camera.field_of_view_deg) / 2)
    # a ray through frame pixel (u, v) (centres at +0.5) runs along
    # forward * focal + right * (u + 0.5 - width / 2) + down * (v + 0.5 - height / 2)
    origin = forward * focal - right * (width / 2 - 0.5) - down * (height / 2 - 0.5)
    ray = np.column_stack((right, down, origin))  # rows x, y, z over (u, v, 1)
    px, py, pz = position
    to_mm = np.vstack((px * ray[2] - pz * ray[0], py * ray[2] - pz * ray[1], ray[2]))
    cx, cy = center_px
    to_px = np.array([[1 / mm_per_px, 0, cx], [0, 1 / mm_per_px, cy], [0, 0, 1]])
    result: npt.NDArray[np.float64] = to_px @ to_mm
    return result


# --- pixels against the symbol ------------------------------------------------------


@dataclass(frozen=True)
class SymbolDamage:
    """How a code on a screen differs from its symbol, in modules."""

    damaged: int  # modules of the symbol with a pixel of the wrong colour
    dirty_quiet: int  # modules of the quiet zone with a pixel that is not white
    modules: int  # modules of the symbol (quiet zone excluded)

    @property
    def intact(self) -> bool:
        return not self.damaged and not self.dirty_quiet


def module_boxes(to_pixels: Affine, rect: tuple[float, float, float, float], modules: int) -> Ints:
    """Each module's whole-pixel box ``(left, top, width, height)`` of a code standing on
    ``rect`` (scene mm, ``modules`` across with its quiet zone) under ``to_pixels``, as
    ``(row, column, 4)``: the twin of ``pixelBox`` in ``static/js/codes.js``, which the
    tiles draw every module with (JavaScript's ``Math.round`` rounds halves up)."""
    x, y, side, _ = rect
    size = side / modules
    a, b, c, d, e, f = to_pixels
    steps = np.arange(modules + 1, dtype=np.float64) * size
    # corners of every module: column edges along x, row edges along y
    xs, ys = x + steps[None, :-1], y + steps[:-1, None]
    x0, y0 = a * xs + c * ys + e, b * xs + d * ys + f
    x1, y1 = a * (xs + size) + c * (ys + size) + e, b * (xs + size) + d * (ys + size) + f
    left = np.floor(np.minimum(x0, x1) + 0.5)
    top = np.floor(np.minimum(y0, y1) + 0.5)
    right = np.floor(np.maximum(x0, x1) + 0.5)
    bottom = np.floor(np.maximum(y0, y1) + 0.5)
    boxes: Ints = np.stack((left, top, right - left, bottom - top), axis=-1).astype(np.int64)
    return boxes


def symbol_damage(picture: npt.NDArray[np.uint8], boxes: Ints, matrix: list[str]) -> SymbolDamage:
    """Compare ``picture`` (rows x columns, grey or RGB) with ``matrix`` (rows of ``1``
    dark, quiet zone excluded) at ``boxes`` (:func:`module_boxes`, quiet zone included).

    A dark module must be black in every pixel and a light one white, each channel
    within :data:`OFF_BY` grey levels: a line, a letter or a box edge across a module
    counts, a faint anti-aliased fringe does not. A module partly off the picture
    counts as wrong (it cannot be seen whole).
    """
    grey = picture if picture.ndim == 3 else picture[..., None]
    height, width = grey.shape[:2]
    across = boxes.shape[0]
    quiet = (across - len(matrix)) // 2
    dark = np.zeros((across, across), dtype=bool)
    dark[quiet : quiet + len(matrix), quiet : quiet + len(matrix)] = [
        [bit == "1" for bit in row] for row in matrix
    ]
    left, top, w, h = (boxes[..., i] for i in range(4))
    right, bottom = left + w, top + h
    seen = (left >= 0) & (top >= 0) & (right <= width) & (bottom <= height) & (w > 0) & (h > 0)
    # only the code's part of the picture is looked at
    x0, y0 = int(np.clip(left.min(), 0, width)), int(np.clip(top.min(), 0, height))
    x1, y1 = int(np.clip(right.max(), x0, width)), int(np.clip(bottom.max(), y0, height))
    part = grey[y0:y1, x0:x1]
    edges = (
        np.clip(left - x0, 0, x1 - x0),
        np.clip(top - y0, 0, y1 - y0),
        np.clip(right - x0, 0, x1 - x0),
        np.clip(bottom - y0, 0, y1 - y0),
    )
    too_light = _box_counts(part.max(axis=2) > OFF_BY, *edges)
    too_dark = _box_counts(part.min(axis=2) < 255 - OFF_BY, *edges)
    wrong = ~seen | (np.where(dark, too_light, too_dark) > 0)
    in_symbol = np.zeros_like(wrong)
    in_symbol[quiet : across - quiet, quiet : across - quiet] = True
    return SymbolDamage(
        damaged=int((wrong & in_symbol).sum()),
        dirty_quiet=int((wrong & ~in_symbol).sum()),
        modules=len(matrix) ** 2,
    )


def _box_counts(
    mask: npt.NDArray[np.bool_], left: Ints, top: Ints, right: Ints, bottom: Ints
) -> Ints:
    """How many pixels of ``mask`` are set in each box (a summed-area table)."""
    table = np.zeros((mask.shape[0] + 1, mask.shape[1] + 1), dtype=np.int64)
    table[1:, 1:] = mask.cumsum(axis=0).cumsum(axis=1)
    counts: Ints = table[bottom, right] - table[top, right] - table[bottom, left] + table[top, left]
    return counts
