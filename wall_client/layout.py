"""Wall geometry: a wall config becomes displays, and each display a viewport.

This module is the only home of wall geometry. The server computes every tile's
viewport here and sends it; tile JavaScript applies the matrices it is given and
never re-derives geometry.

Coordinates are physical millimetres on the wall, origin at the top-left corner,
x to the right, y downwards. The *scene* is authored in the same coordinates over
the wall's full extent. In bezel mode ``overlay`` a display shows exactly the scene
under its active area (what lies behind a bezel is hidden, lines stay straight).
In mode ``offset`` the uncovered bands (bezels, gaps) are squeezed out along each
axis and the remaining coverage is stretched back to the wall's extent, so the
pixels of neighbouring displays are concatenated.

Rotation convention: ``Display.rotation`` is the clockwise rotation of the panel as
mounted, and ``Display.resolution`` its native (unrotated) framebuffer. The OS does
*not* rotate the output: the browser window of every display is its native
resolution (``Viewport.pixels == resolution``), and ``Viewport.to_pixels`` carries the
rotation, so content drawn through it appears upright on the turned panel. For a
panel turned 90 degrees clockwise, the framebuffer's top edge runs down the right
side of the display as seen on the wall, and its top-left pixel sits at the display's
top-right corner.

Wall configs are TOML; docs/wall-config.md documents every key.
"""

from __future__ import annotations

import bisect
import math
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, cast

BezelMode = Literal["overlay", "offset"]
CodePurpose = Literal["walk-up", "seat"]
Rotation = Literal[0, 90, 180, 270]
ROLES: tuple[str, ...] = ("public", "menu", "registration")

# An affine map (a, b, c, d, e, f) as in CSS/canvas ``setTransform``:
# x' = a*x + c*y + e ; y' = b*x + d*y + f
Affine = tuple[float, float, float, float, float, float]

IDENTITY: Affine = (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
BEZEL_MODES: tuple[str, ...] = ("overlay", "offset")
ROTATIONS: tuple[int, ...] = (0, 90, 180, 270)

# Every key the parser accepts, per table (tests check each is documented).
TOP_KEYS: tuple[str, ...] = (
    "id",
    "name",
    "bezel_mode",
    "seat_distance_m",
    "walk_up_distance_m",
    "screens",
    "wall",
    "grid",
    "display",
)
WALL_KEYS: tuple[str, ...] = ("width_mm", "height_mm")
STAGE = "stage"  # the [screens] key naming the displays the scene is framed on
SCREEN_KEYS: tuple[str, ...] = (*ROLES, STAGE)
GRID_KEYS: tuple[str, ...] = (
    "columns",
    "rows",
    "resolution",
    "active_mm",
    "bezel_mm",
    "gap_mm",
    "displays_per_node",
    "node_prefix",
    "rotation",
)
BEZEL_SIDES: tuple[str, ...] = ("left", "right", "top", "bottom")
DISPLAY_KEYS: tuple[str, ...] = (
    "id",
    "x_mm",
    "y_mm",
    "width_mm",
    "height_mm",
    "resolution",
    "rotation",
    "node",
    "index",
    "desktop_origin",
)

DEFAULT_SEAT_DISTANCE_M = 2.0
DEFAULT_WALK_UP_DISTANCE_M = 0.8
STAGE_ASPECT = (4, 3)  # the picture the default stage is chosen for: a bit wider than tall
RENAMED_KEYS = {"scan_distance_m": "seat_distance_m"}
DEFAULT_NODE = "node1"
# Largest tolerated difference between horizontal and vertical pixel pitch.
ASPECT_TOLERANCE = 0.03
# Slack for comparing positions computed in floating point (a micrometre).
EPSILON_MM = 1e-3

_WALL_ID = re.compile(r"[a-z0-9-]+")
_DISPLAY_ID = re.compile(r"[A-Za-z0-9_-]+")  # display ids end up in tile URLs
_NODE_NAME = re.compile(r"[A-Za-z0-9_.-]+")  # node names are host-like


class WallConfigError(ValueError):
    """A wall config is invalid; ``errors`` holds every problem found, one per line."""

    def __init__(self, errors: Sequence[str]) -> None:
        self.errors: list[str] = list(errors)
        super().__init__("\n".join(self.errors))

    def __str__(self) -> str:
        return "\n".join(self.errors)


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in wall millimetres."""

    x: float
    y: float
    width: float
    height: float

    @property
    def xywh(self) -> tuple[float, float, float, float]:
        """The rectangle as ``(x, y, width, height)``, as messages and canvases take it."""
        return (self.x, self.y, self.width, self.height)

    @property
    def right(self) -> float:
        return self.x + self.width

    @property
    def bottom(self) -> float:
        return self.y + self.height

    @property
    def center(self) -> tuple[float, float]:
        return (self.x + self.width / 2, self.y + self.height / 2)

    def intersects(self, other: Rect) -> bool:
        """True when the two overlap with positive area; touching edges do not count."""
        overlap_w = min(self.right, other.right) - max(self.x, other.x)
        overlap_h = min(self.bottom, other.bottom) - max(self.y, other.y)
        return overlap_w > 0 and overlap_h > 0

    def contains(self, other: Rect | tuple[float, float]) -> bool:
        """True when a point or rectangle lies inside, edges included."""
        if isinstance(other, Rect):
            return (
                self.x <= other.x
                and other.right <= self.right
                and self.y <= other.y
                and other.bottom <= self.bottom
            )
        px, py = other
        return self.x <= px <= self.right and self.y <= py <= self.bottom


@dataclass(frozen=True)
class Display:
    """One monitor: its active area on the wall and how it is driven."""

    id: str
    rect: Rect  # active area as mounted, wall mm
    resolution: tuple[int, int]  # native framebuffer pixels (unrotated), as the OS drives it
    rotation: Rotation  # clockwise rotation of the panel as mounted
    node: str  # render node (host) that drives it, for the kiosk launcher
    index: int  # display index on that node (0 = primary)
    desktop_origin: tuple[int, int]  # top-left of this display in the node's desktop, px

    @property
    def mounted_resolution(self) -> tuple[int, int]:
        """Pixels along the wall's x and y axes: the native resolution, swapped when turned."""
        w, h = self.resolution
        return (h, w) if self.rotation in (90, 270) else (w, h)

    @property
    def mm_per_px(self) -> float:
        """Physical pixel pitch as mounted (mean of both axes; validation keeps them close).

        Tag sizing needs it: a QR module must span enough millimetres to scan.
        """
        px_w, px_h = self.mounted_resolution
        return (self.rect.width / px_w + self.rect.height / px_h) / 2


@dataclass(frozen=True)
class Viewport:
    """What one tile shows: a scene rectangle and the maps that draw it."""

    display_id: str
    scene_rect: Rect  # part of the scene this display shows (scene mm)
    pixels: tuple[int, int]  # window size in px (the native resolution)
    to_pixels: Affine  # scene mm -> window px (rotation included)
    to_wall: Affine  # scene mm -> physical wall mm (identity in overlay mode)

    def px_to_mm(self, px: float) -> float:
        """A length in this display's pixels as scene mm (the longer, where the axes
        differ), for marks drawn a fixed number of pixels wide."""
        a, b, c, d, _, _ = self.to_pixels
        return px / min(math.hypot(a, b), math.hypot(c, d))

    def shows(self, rect: Rect) -> bool:
        """Whether any of ``rect`` (scene mm) falls on this display."""
        return self.scene_rect.intersects(rect)

    def shows_segment(
        self, start: tuple[float, float], end: tuple[float, float], reach_px: float
    ) -> bool:
        """Whether a line from ``start`` to ``end`` (scene mm), drawn with marks up to
        ``reach_px`` pixels around it (its width, a disc at its end), falls on this
        display. The marks are taken as squares, so a line that just misses a corner
        may count: a tile clips what it draws, so a spare one costs nothing."""
        reach = self.px_to_mm(reach_px)
        rect = self.scene_rect
        (x0, y0), (x1, y1) = start, end
        # Liang-Barsky: clip the segment's parameter range [0, 1] to the grown rectangle.
        low, high = 0.0, 1.0
        for delta, distance in (
            (-(x1 - x0), x0 - (rect.x - reach)),
            (x1 - x0, rect.right + reach - x0),
            (-(y1 - y0), y0 - (rect.y - reach)),
            (y1 - y0, rect.bottom + reach - y0),
        ):
            if delta == 0:
                if distance < 0:
                    return False
                continue
            t = distance / delta
            if delta < 0:
                low = max(low, t)
            else:
                high = min(high, t)
        return low <= high


@dataclass(frozen=True)
class Wall:
    """A validated wall: displays, designated screens, bezel mode.

    Viewports are computed once, when the wall is built, since every tile page and
    websocket hello asks for them.
    """

    id: str
    name: str
    width: float  # wall extent, mm
    height: float
    displays: tuple[Display, ...]
    bezel_mode: BezelMode
    screens: dict[str, tuple[str, ...]]  # role -> display ids
    seat_distance_m: float  # where people scan seat codes (registration, menus) from
    walk_up_distance_m: float = DEFAULT_WALK_UP_DISTANCE_M  # codes marking the scene
    stage_ids: tuple[str, ...] = ()  # displays the scene is framed on (empty: computed)
    source: Path | None = None
    _by_id: dict[str, Display] = field(init=False, repr=False, compare=False)
    _viewports: dict[str, Viewport] = field(init=False, repr=False, compare=False)
    _stage: Rect = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        by_id = {display.id: display for display in self.displays}
        if len(by_id) != len(self.displays):
            raise ValueError(f"wall {self.id!r}: display ids are not unique")
        object.__setattr__(self, "_by_id", by_id)
        object.__setattr__(self, "_viewports", _compute_viewports(self))
        if not self.stage_ids:
            object.__setattr__(self, "stage_ids", _free_stage(self))
        object.__setattr__(self, "_stage", _bounding(self, self.stage_ids))

    @property
    def stage(self) -> Rect:
        """The scene rectangle (scene mm) a scene is framed on at zoom 1 and centre
        (0.5, 0.5): by default the largest block of displays free of designated
        screens, so the picture does not lie under panels and codes can stand beside
        what they mark."""
        return self._stage

    def design_distance_m(self, purpose: CodePurpose) -> float:
        """How far people stand from a code of ``purpose``: *walk-up* codes mark things
        on the scene (people step up to them), *seat* codes serve the room."""
        return self.walk_up_distance_m if purpose == "walk-up" else self.seat_distance_m

    def designated(self) -> set[str]:
        """Ids of the displays that carry panels (public, menu, registration)."""
        return {display_id for role in ROLES for display_id in self.screens.get(role, ())}

    def display(self, display_id: str) -> Display:
        """The display called ``display_id``; KeyError naming the wall otherwise."""
        try:
            return self._by_id[display_id]
        except KeyError:
            known = ", ".join(self._by_id)
            raise KeyError(
                f"wall {self.id!r} has no display {display_id!r} (displays: {known})"
            ) from None

    def viewport(self, display_id: str) -> Viewport:
        """The viewport of one display."""
        self.display(display_id)  # for the clear KeyError
        return self._viewports[display_id]

    def viewports(self) -> dict[str, Viewport]:
        """Every display's viewport, in display order."""
        return dict(self._viewports)

    def screen(self, role: str) -> tuple[Display, ...]:
        """The displays designated for ``role`` (empty when none are)."""
        if role not in ROLES:
            raise KeyError(f"unknown screen role {role!r} (roles: {', '.join(ROLES)})")
        return tuple(self._by_id[i] for i in self.screens.get(role, ()))

    def nodes(self) -> dict[str, tuple[Display, ...]]:
        """Displays per render node (nodes in order of first appearance), ordered by index."""
        grouped: dict[str, list[Display]] = {}
        for display in self.displays:
            grouped.setdefault(display.node, []).append(display)
        return {
            node: tuple(sorted(displays, key=lambda d: d.index))
            for node, displays in grouped.items()
        }


# --- affine maps -------------------------------------------------------------------


def apply_affine(m: Affine, x: float, y: float) -> tuple[float, float]:
    """Map a point, with the same convention as canvas ``setTransform``."""
    a, b, c, d, e, f = m
    return (a * x + c * y + e, b * x + d * y + f)


def compose_affine(outer: Affine, inner: Affine) -> Affine:
    """The map that applies ``inner`` first, then ``outer``."""
    a2, b2, c2, d2, e2, f2 = outer
    a1, b1, c1, d1, e1, f1 = inner
    return (
        a2 * a1 + c2 * b1,
        b2 * a1 + d2 * b1,
        a2 * c1 + c2 * d1,
        b2 * c1 + d2 * d1,
        a2 * e1 + c2 * f1 + e2,
        b2 * e1 + d2 * f1 + f2,
    )


def invert_affine(m: Affine) -> Affine:
    """The inverse map; ValueError when ``m`` is singular."""
    a, b, c, d, e, f = m
    det = a * d - b * c
    if det == 0 or not math.isfinite(det):
        raise ValueError(f"affine map {m} is not invertible")
    return (
        d / det,
        -b / det,
        -c / det,
        a / det,
        (c * f - d * e) / det,
        (b * e - a * f) / det,
    )


# Unit square (u, v) on the wall, u rightwards and v downwards, to the native
# framebuffer scaled to 1 x 1, for a panel turned clockwise by the key.
_UNIT_TO_FRAMEBUFFER: dict[int, Affine] = {
    0: (1.0, 0.0, 0.0, 1.0, 0.0, 0.0),  # X = u, Y = v
    90: (0.0, -1.0, 1.0, 0.0, 0.0, 1.0),  # X = v, Y = 1 - u
    180: (-1.0, 0.0, 0.0, -1.0, 1.0, 1.0),  # X = 1 - u, Y = 1 - v
    270: (0.0, 1.0, -1.0, 0.0, 1.0, 0.0),  # X = 1 - v, Y = u
}


def _rect_to_pixels(scene: Rect, pixels: tuple[int, int], rotation: int) -> Affine:
    """Scene mm inside ``scene`` to window px of a display turned by ``rotation``."""
    to_unit: Affine = (
        1 / scene.width,
        0.0,
        0.0,
        1 / scene.height,
        -scene.x / scene.width,
        -scene.y / scene.height,
    )
    w, h = pixels
    scale: Affine = (float(w), 0.0, 0.0, float(h), 0.0, 0.0)
    return compose_affine(scale, compose_affine(_UNIT_TO_FRAMEBUFFER[rotation], to_unit))


def _rect_to_rect(src: Rect, dst: Rect) -> Affine:
    """The axis-aligned affine map taking ``src`` onto ``dst``."""
    sx = dst.width / src.width
    sy = dst.height / src.height
    return (sx, 0.0, 0.0, sy, dst.x - src.x * sx, dst.y - src.y * sy)


# --- viewports ---------------------------------------------------------------------


class _Squeeze:
    """Offset mode along one axis: wall mm -> scene mm, squeezing out uncovered bands.

    Covered intervals keep their order and are stretched uniformly so that together
    they span [0, extent]; the map is monotone and piecewise linear, and neighbouring
    covered intervals meet at exactly the same scene coordinate.
    """

    def __init__(self, intervals: Iterable[tuple[float, float]], extent: float) -> None:
        merged: list[list[float]] = []
        for start, end in sorted(intervals):
            if merged and start <= merged[-1][1]:
                merged[-1][1] = max(merged[-1][1], end)
            else:
                merged.append([start, end])
        self.starts = [start for start, _ in merged]
        self.ends = [end for _, end in merged]
        self.before: list[float] = []  # covered length before each interval
        covered = 0.0
        for start, end in merged:
            self.before.append(covered)
            covered += end - start
        self.covered = covered
        self.extent = extent

    def __call__(self, t: float) -> float:
        i = bisect.bisect_right(self.starts, t) - 1
        if i < 0 or self.covered <= 0:
            return 0.0
        covered = self.before[i] + min(t, self.ends[i]) - self.starts[i]
        if covered >= self.covered:
            return self.extent
        return covered * self.extent / self.covered


def _compute_viewports(wall: Wall) -> dict[str, Viewport]:
    """Every display's viewport under the wall's bezel mode."""
    if wall.bezel_mode == "offset":
        along_x = _Squeeze(((d.rect.x, d.rect.right) for d in wall.displays), wall.width)
        along_y = _Squeeze(((d.rect.y, d.rect.bottom) for d in wall.displays), wall.height)
    viewports: dict[str, Viewport] = {}
    for display in wall.displays:
        rect = display.rect
        if wall.bezel_mode == "offset":
            x0, x1 = along_x(rect.x), along_x(rect.right)
            y0, y1 = along_y(rect.y), along_y(rect.bottom)
            scene = Rect(x0, y0, x1 - x0, y1 - y0)
            to_wall = _rect_to_rect(scene, rect)
        else:
            scene, to_wall = rect, IDENTITY
        viewports[display.id] = Viewport(
            display_id=display.id,
            scene_rect=scene,
            pixels=display.resolution,
            to_pixels=_rect_to_pixels(scene, display.resolution, display.rotation),
            to_wall=to_wall,
        )
    return viewports


def _bounding(wall: Wall, display_ids: Sequence[str]) -> Rect:
    """The scene rectangle around the viewports of ``display_ids`` (all of them: the
    whole wall, margins and outer bezels included)."""
    if set(display_ids) == set(wall._by_id):
        return Rect(0.0, 0.0, wall.width, wall.height)
    rects = [wall.viewport(i).scene_rect for i in display_ids]
    x0, y0 = min(r.x for r in rects), min(r.y for r in rects)
    x1, y1 = max(r.right for r in rects), max(r.bottom for r in rects)
    return Rect(x0, y0, x1 - x0, y1 - y0)


def _free_stage(wall: Wall) -> tuple[str, ...]:
    """The displays inside the largest rectangle of the wall that no designated screen
    overlaps: the one holding the largest 4:3 picture (a brain seen from the side, a
    county; a bit wider than tall), then the largest, then the topmost-leftmost. All
    displays when none is free."""
    designated = [d.rect for d in wall.displays if d.id in wall.designated()]
    free = [d for d in wall.displays if d.id not in wall.designated()]
    if not designated or not free:
        return tuple(d.id for d in wall.displays)
    xs = sorted({v for d in free for v in (d.rect.x, d.rect.right)})
    ys = sorted({v for d in free for v in (d.rect.y, d.rect.bottom)})
    best: tuple[float, float, float, float] | None = None
    chosen: tuple[str, ...] = ()
    for i, x0 in enumerate(xs):
        for x1 in xs[i + 1 :]:
            for j, y0 in enumerate(ys):
                for y1 in ys[j + 1 :]:
                    area = Rect(x0, y0, x1 - x0, y1 - y0)
                    if any(area.intersects(r) for r in designated):
                        break  # a taller rectangle from the same top overlaps too
                    inside = tuple(d.id for d in free if area.contains(d.rect))
                    if not inside:
                        continue
                    picture = min(area.width / STAGE_ASPECT[0], area.height / STAGE_ASPECT[1])
                    score = (picture, area.width * area.height, -y0, -x0)
                    if best is None or score > best:
                        best, chosen = score, inside
    return chosen or tuple(d.id for d in free)


# --- parsing -----------------------------------------------------------------------


class _Problems:
    """Collects "FILE: field.path: message" lines so one run reports every problem."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.messages: list[str] = []

    def add(self, path: str, message: str) -> None:
        self.messages.append(f"{self.label}: {path}: {message}")

    def unknown_keys(self, table: Mapping[str, Any], allowed: Sequence[str], path: str) -> None:
        for key in table:
            if key not in allowed:
                self.add(f"{path}{key}", f"unknown key (expected one of: {', '.join(allowed)})")

    def table(self, value: Any, path: str) -> dict[str, Any] | None:
        if isinstance(value, dict):
            return value
        self.add(path, "must be a table")
        return None

    def string(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: str | None = None,
        pattern: re.Pattern[str] | None = None,
        describe: str = "",
    ) -> str | None:
        if key not in table:
            if default is None:
                self.add(path, "required")
            return default
        value = table[key]
        if not isinstance(value, str) or not value:
            self.add(path, "must be a non-empty string")
            return None
        if pattern is not None and not pattern.fullmatch(value):
            self.add(path, f"{value!r} must use only {describe}")
            return None
        return value

    def number(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: float | None = None,
        minimum: Literal["positive", "non-negative", "any"] = "positive",
    ) -> float | None:
        if key not in table:
            if default is None:
                self.add(path, "required")
            return default
        return self.number_value(table[key], path, minimum=minimum)

    def number_value(
        self,
        value: Any,
        path: str,
        *,
        minimum: Literal["positive", "non-negative", "any"] = "positive",
    ) -> float | None:
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.add(path, "must be a number")
            return None
        if not math.isfinite(value):
            self.add(path, "must be a finite number")
            return None
        if minimum == "positive" and value <= 0:
            self.add(path, "must be positive")
            return None
        if minimum == "non-negative" and value < 0:
            self.add(path, "must not be negative")
            return None
        return float(value)

    def integer(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: int | None = None,
        minimum: int = 1,
    ) -> int | None:
        if key not in table:
            if default is None:
                self.add(path, "required")
            return default
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(path, "must be an integer")
            return None
        if value < minimum:
            self.add(path, "must be positive" if minimum == 1 else f"must be at least {minimum}")
            return None
        return value

    def rotation(self, table: Mapping[str, Any], key: str, path: str) -> Rotation | None:
        value = table.get(key, 0)
        if isinstance(value, bool) or value not in ROTATIONS:
            self.add(path, f"must be one of 0, 90, 180, 270 (got {value!r})")
            return None
        return cast(Rotation, int(value))

    def pair(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        integers: bool,
        minimum: Literal["positive", "non-negative", "any"] = "positive",
        required: bool = True,
    ) -> tuple[float, float] | None:
        if key not in table:
            if required:
                self.add(path, "required")
            return None
        value = table[key]
        kind = "integers" if integers else "numbers"
        if not isinstance(value, list) or len(value) != 2:
            self.add(path, f"must be a pair of {kind}, like [1920, 1080]")
            return None
        if integers and any(isinstance(v, bool) or not isinstance(v, int) for v in value):
            self.add(path, f"must be a pair of {kind}, like [1920, 1080]")
            return None
        first = self.number_value(value[0], f"{path}[0]", minimum=minimum)
        second = self.number_value(value[1], f"{path}[1]", minimum=minimum)
        if first is None or second is None:
            return None
        return (first, second)

    def int_pair(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        minimum: Literal["positive", "non-negative", "any"] = "positive",
        required: bool = True,
    ) -> tuple[int, int] | None:
        got = self.pair(table, key, path, integers=True, minimum=minimum, required=required)
        return None if got is None else (int(got[0]), int(got[1]))

    def square_pixels(
        self, width_mm: float, height_mm: float, mounted: tuple[int, int], path: str
    ) -> None:
        """Pixels must be (nearly) square, or the config's size or resolution is wrong."""
        pitch_ratio = (width_mm / mounted[0]) / (height_mm / mounted[1])
        if abs(pitch_ratio - 1) > ASPECT_TOLERANCE:
            self.add(
                path,
                f"active area {width_mm:g} x {height_mm:g} mm (aspect {width_mm / height_mm:.3f})"
                f" does not match {mounted[0]} x {mounted[1]} px as mounted"
                f" (aspect {mounted[0] / mounted[1]:.3f}): pixels would not be square"
                f" (off by {abs(pitch_ratio - 1):.1%}, more than {ASPECT_TOLERANCE:.0%})",
            )


@dataclass
class _Parsed:
    """Displays read from either form, with where each came from for messages."""

    displays: list[Display]
    paths: list[str]  # per display, the config path naming it in messages
    size: tuple[float, float]  # natural wall size when [wall] does not give one
    known_ids: set[str]  # every display id seen, even on entries with other errors


def _mounted(resolution: tuple[int, int], rotation: int) -> tuple[int, int]:
    w, h = resolution
    return (h, w) if rotation in (90, 270) else (w, h)


def _parse_grid(problems: _Problems, grid: dict[str, Any]) -> _Parsed | None:
    problems.unknown_keys(grid, GRID_KEYS, "grid.")
    columns = problems.integer(grid, "columns", "grid.columns")
    rows = problems.integer(grid, "rows", "grid.rows")
    resolution = problems.int_pair(grid, "resolution", "grid.resolution")
    active = problems.pair(grid, "active_mm", "grid.active_mm", integers=False)
    bezel = _parse_bezel(problems, grid)
    gap = _parse_gap(problems, grid)
    per_node = problems.integer(grid, "displays_per_node", "grid.displays_per_node", default=1)
    prefix = problems.string(
        grid,
        "node_prefix",
        "grid.node_prefix",
        default="node",
        pattern=_NODE_NAME,
        describe="letters, digits, '_', '.' and '-'",
    )
    rotation = problems.rotation(grid, "rotation", "grid.rotation")
    if (
        columns is None
        or rows is None
        or resolution is None
        or active is None
        or bezel is None
        or gap is None
        or per_node is None
        or prefix is None
        or rotation is None
    ):
        return None
    problems.square_pixels(active[0], active[1], _mounted(resolution, rotation), "grid.active_mm")
    left, right, top, bottom = bezel
    pitch_x = left + active[0] + right + gap[0]
    pitch_y = top + active[1] + bottom + gap[1]
    displays: list[Display] = []
    for i in range(columns * rows):
        row, col = divmod(i, columns)
        index = i % per_node
        displays.append(
            Display(
                id=f"r{row + 1}c{col + 1}",
                rect=Rect(col * pitch_x + left, row * pitch_y + top, active[0], active[1]),
                resolution=resolution,
                rotation=rotation,
                node=f"{prefix}{i // per_node + 1}",
                index=index,
                # The OS does not rotate: windows sit side by side at native width.
                desktop_origin=(index * resolution[0], 0),
            )
        )
    return _Parsed(
        displays=displays,
        paths=["grid"] * len(displays),
        size=(columns * pitch_x - gap[0], rows * pitch_y - gap[1]),
        known_ids={d.id for d in displays},
    )


def _parse_bezel(
    problems: _Problems, grid: Mapping[str, Any]
) -> tuple[float, float, float, float] | None:
    """``bezel_mm`` as (left, right, top, bottom): one number for all sides, or a table."""
    if "bezel_mm" not in grid:
        problems.add("grid.bezel_mm", "required (0 for bezel-less panels)")
        return None
    value = grid["bezel_mm"]
    if isinstance(value, dict):
        problems.unknown_keys(value, BEZEL_SIDES, "grid.bezel_mm.")
        sides = [
            problems.number(value, side, f"grid.bezel_mm.{side}", minimum="non-negative")
            for side in BEZEL_SIDES
        ]
        left, right, top, bottom = sides
        if left is None or right is None or top is None or bottom is None:
            return None
        return (left, right, top, bottom)
    width = problems.number_value(value, "grid.bezel_mm", minimum="non-negative")
    return None if width is None else (width, width, width, width)


def _parse_gap(problems: _Problems, grid: Mapping[str, Any]) -> tuple[float, float] | None:
    """``gap_mm`` as (x, y): one number for both axes, or a pair."""
    value = grid.get("gap_mm", 0)
    if isinstance(value, list):
        return problems.pair(grid, "gap_mm", "grid.gap_mm", integers=False, minimum="non-negative")
    gap = problems.number_value(value, "grid.gap_mm", minimum="non-negative")
    return None if gap is None else (gap, gap)


@dataclass
class _Entry:
    """One ``[[display]]`` entry before node indices and desktop origins are filled in."""

    path: str
    id: str
    rect: Rect
    resolution: tuple[int, int]
    rotation: Rotation
    node: str
    index: int | None
    desktop_origin: tuple[int, int] | None


def _parse_displays(problems: _Problems, entries: Any) -> _Parsed | None:
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        problems.add("display", "must be an array of tables, written as [[display]] sections")
        return None
    if not entries:
        problems.add("display", "at least one [[display]] is required")
        return None
    parsed: list[_Entry] = []
    known_ids: set[str] = set()
    first_path: dict[str, str] = {}
    for i, table in enumerate(entries):
        p = f"display[{i}]"
        problems.unknown_keys(table, DISPLAY_KEYS, f"{p}.")
        display_id = problems.string(
            table, "id", f"{p}.id", pattern=_DISPLAY_ID, describe="letters, digits, '_' and '-'"
        )
        if display_id is not None:
            known_ids.add(display_id)
            if display_id in first_path:
                problems.add(
                    f"{p}.id",
                    f"duplicate display id {display_id!r} (also {first_path[display_id]})",
                )
                display_id = None
            else:
                first_path[display_id] = p
        x = problems.number(table, "x_mm", f"{p}.x_mm", minimum="any")
        y = problems.number(table, "y_mm", f"{p}.y_mm", minimum="any")
        width = problems.number(table, "width_mm", f"{p}.width_mm")
        height = problems.number(table, "height_mm", f"{p}.height_mm")
        resolution = problems.int_pair(table, "resolution", f"{p}.resolution")
        rotation = problems.rotation(table, "rotation", f"{p}.rotation")
        node = problems.string(
            table,
            "node",
            f"{p}.node",
            default=DEFAULT_NODE,
            pattern=_NODE_NAME,
            describe="letters, digits, '_', '.' and '-'",
        )
        index: int | None = None
        if "index" in table:
            index = problems.integer(table, "index", f"{p}.index", minimum=0)
            if index is None:
                continue
        origin = problems.int_pair(
            table, "desktop_origin", f"{p}.desktop_origin", minimum="any", required=False
        )
        if "desktop_origin" in table and origin is None:
            continue
        if (
            display_id is None
            or x is None
            or y is None
            or width is None
            or height is None
            or resolution is None
            or rotation is None
            or node is None
        ):
            continue
        problems.square_pixels(width, height, _mounted(resolution, rotation), f"{p}.resolution")
        rect = Rect(x, y, width, height)
        parsed.append(_Entry(p, display_id, rect, resolution, rotation, node, index, origin))
    displays = _place_on_nodes(problems, parsed)
    return _Parsed(
        displays=displays,
        paths=[entry.path for entry in parsed],
        size=(
            max((d.rect.right for d in displays), default=0.0),
            max((d.rect.bottom for d in displays), default=0.0),
        ),
        known_ids=known_ids,
    )


def _place_on_nodes(problems: _Problems, entries: list[_Entry]) -> list[Display]:
    """Fill in default node indices and desktop origins, in the entries' order."""
    appeared: dict[str, int] = {}
    indices: list[int] = []
    for entry in entries:
        position = appeared.get(entry.node, 0)
        appeared[entry.node] = position + 1
        indices.append(position if entry.index is None else entry.index)
    taken: dict[tuple[str, int], str] = {}
    for entry, index in zip(entries, indices, strict=True):
        key = (entry.node, index)
        if key in taken:
            problems.add(
                f"{entry.path}.index",
                f"index {index} on node {entry.node!r} is already used by {taken[key]}",
            )
        else:
            taken[key] = entry.path
    origins: list[tuple[int, int]] = []
    for entry, index in zip(entries, indices, strict=True):
        if entry.desktop_origin is not None:
            origins.append(entry.desktop_origin)
            continue
        # The OS does not rotate, so every window is native width, side by side by index.
        left = sum(
            other.resolution[0]
            for other, other_index in zip(entries, indices, strict=True)
            if other.node == entry.node and other_index < index
        )
        origins.append((left, 0))
    return [
        Display(
            id=entry.id,
            rect=entry.rect,
            resolution=entry.resolution,
            rotation=entry.rotation,
            node=entry.node,
            index=index,
            desktop_origin=origin,
        )
        for entry, index, origin in zip(entries, indices, origins, strict=True)
    ]


def _check_placement(
    problems: _Problems, parsed: _Parsed, width: float, height: float, explicit_size: bool
) -> None:
    """Displays must not overlap and must lie on the wall."""
    margin = Rect(-EPSILON_MM, -EPSILON_MM, width + 2 * EPSILON_MM, height + 2 * EPSILON_MM)
    size = "wall.width_mm x wall.height_mm" if explicit_size else "the wall's extent"
    for display, path in zip(parsed.displays, parsed.paths, strict=True):
        r = display.rect
        if margin.contains(r):
            continue
        if path == "grid":  # a grid only leaves the wall when [wall] is too small
            if r.right > margin.right:
                problems.add(
                    "wall.width_mm",
                    f"display outside the wall: {display.id} reaches x = {r.right:g} mm,"
                    f" beyond {width:g} mm",
                )
            if r.bottom > margin.bottom:
                problems.add(
                    "wall.height_mm",
                    f"display outside the wall: {display.id} reaches y = {r.bottom:g} mm,"
                    f" beyond {height:g} mm",
                )
        else:
            problems.add(
                path,
                f"display outside the wall: {r.x:g}..{r.right:g} x {r.y:g}..{r.bottom:g} mm"
                f" is not within {size} {width:g} x {height:g} mm",
            )
    for i, (a, a_path) in enumerate(zip(parsed.displays, parsed.paths, strict=True)):
        for b, b_path in zip(parsed.displays[:i], parsed.paths[:i], strict=True):
            overlap_w = min(a.rect.right, b.rect.right) - max(a.rect.x, b.rect.x)
            overlap_h = min(a.rect.bottom, b.rect.bottom) - max(a.rect.y, b.rect.y)
            if overlap_w > EPSILON_MM and overlap_h > EPSILON_MM:
                problems.add(
                    a_path,
                    f"display {a.id!r} overlaps display {b.id!r} ({b_path})"
                    f" by {overlap_w:g} x {overlap_h:g} mm",
                )


def _parse_screens(
    problems: _Problems, value: Any, parsed: _Parsed | None
) -> tuple[dict[str, tuple[str, ...]], tuple[str, ...]]:
    """The displays of each role, and the stage's (empty: the wall computes it)."""
    screens: dict[str, tuple[str, ...]] = {}
    stage: tuple[str, ...] = ()
    table = problems.table(value, "screens") if value is not None else {}
    for role, ids in (table or {}).items():
        path = f"screens.{role}"
        if role not in SCREEN_KEYS:
            problems.add(path, f"unknown role (roles: {', '.join(SCREEN_KEYS)})")
            continue
        listed = [ids] if isinstance(ids, str) else ids
        if not isinstance(listed, list) or not all(isinstance(i, str) for i in listed):
            problems.add(path, "must be a display id or a list of display ids")
            continue
        for display_id in listed:
            if parsed is not None and display_id not in parsed.known_ids:
                problems.add(path, f"unknown display {display_id!r}")
        if len(set(listed)) != len(listed):
            problems.add(path, "lists a display more than once")
        if role == STAGE:
            if not listed:
                problems.add(path, "give at least one display (leave it out for the default)")
            stage = tuple(listed)
        else:
            screens[role] = tuple(listed)
    if parsed is not None and "registration" not in screens and parsed.displays:
        # Lower left: people register where they walk up, usually a corner at eye level.
        lower_left = min(parsed.displays, key=lambda d: (-d.rect.bottom, d.rect.x))
        screens["registration"] = (lower_left.id,)
    for role in ROLES:
        screens.setdefault(role, ())
    return {role: screens[role] for role in ROLES}, stage


def parse_wall(data: Mapping[str, Any], source: str | Path | None = None) -> Wall:
    """Validate a parsed TOML document into a Wall; WallConfigError lists every problem."""
    problems = _Problems(str(source) if source is not None else "<string>")
    for old, new in RENAMED_KEYS.items():
        if old in data:
            problems.add(old, f"renamed: use {new} (walk-up codes have walk_up_distance_m)")
    problems.unknown_keys({k: v for k, v in data.items() if k not in RENAMED_KEYS}, TOP_KEYS, "")
    wall_id = problems.string(
        data, "id", "id", pattern=_WALL_ID, describe="lowercase letters, digits and '-'"
    )
    name = problems.string(data, "name", "name", default=wall_id or "")
    bezel_mode = data.get("bezel_mode", "overlay")
    if bezel_mode not in BEZEL_MODES:
        problems.add("bezel_mode", f"must be one of {', '.join(BEZEL_MODES)} (got {bezel_mode!r})")
    seat_distance = problems.number(
        data, "seat_distance_m", "seat_distance_m", default=DEFAULT_SEAT_DISTANCE_M
    )
    walk_up_distance = problems.number(
        data, "walk_up_distance_m", "walk_up_distance_m", default=DEFAULT_WALK_UP_DISTANCE_M
    )

    parsed: _Parsed | None = None
    if "grid" in data and "display" in data:
        problems.add("grid", "give either a [grid] table or [[display]] entries, not both")
    elif "grid" in data:
        grid = problems.table(data["grid"], "grid")
        parsed = _parse_grid(problems, grid) if grid is not None else None
    elif "display" in data:
        parsed = _parse_displays(problems, data["display"])
    else:
        problems.add("grid", "missing: give either a [grid] table or [[display]] entries")

    width = height = 0.0
    explicit_size = False
    wall_table = problems.table(data["wall"], "wall") if "wall" in data else {}
    if wall_table is not None:
        problems.unknown_keys(wall_table, WALL_KEYS, "wall.")
        explicit_size = bool(set(wall_table) & set(WALL_KEYS))
        natural = parsed.size if parsed is not None else (0.0, 0.0)
        width = problems.number(wall_table, "width_mm", "wall.width_mm", default=natural[0]) or 0
        height = problems.number(wall_table, "height_mm", "wall.height_mm", default=natural[1]) or 0
    if parsed is not None and wall_table is not None:
        _check_placement(problems, parsed, width, height, explicit_size)

    screens, stage = _parse_screens(problems, data.get("screens"), parsed)

    if problems.messages or parsed is None or wall_id is None:
        raise WallConfigError(problems.messages or [f"{problems.label}: invalid wall config"])
    return Wall(
        id=wall_id,
        name=name or wall_id,
        width=width,
        height=height,
        displays=tuple(parsed.displays),
        bezel_mode=cast(BezelMode, bezel_mode),
        screens=screens,
        seat_distance_m=seat_distance or DEFAULT_SEAT_DISTANCE_M,
        walk_up_distance_m=walk_up_distance or DEFAULT_WALK_UP_DISTANCE_M,
        stage_ids=stage,
        source=Path(source) if source is not None else None,
    )


def load_wall(path: str | Path) -> Wall:
    """Read and validate one TOML wall config; unreadable files are config errors too."""
    path = Path(path)
    try:
        with path.open("rb") as file:
            data = tomllib.load(file)
    except FileNotFoundError:
        raise WallConfigError([f"{path}: no such file"]) from None
    except IsADirectoryError:
        raise WallConfigError([f"{path}: is a directory, expected a .toml file"]) from None
    except OSError as error:
        raise WallConfigError([f"{path}: cannot read: {error.strerror or error}"]) from None
    except UnicodeDecodeError as error:
        raise WallConfigError([f"{path}: not UTF-8 text: {error}"]) from None
    except tomllib.TOMLDecodeError as error:
        raise WallConfigError([f"{path}: TOML syntax error: {error}"]) from None
    return parse_wall(data, path)


def load_walls(paths: Iterable[str | Path]) -> dict[str, Wall]:
    """Load every wall from files and folders of ``*.toml`` (sorted by name), keyed by id.

    Problems in all files are reported together, and a wall id used twice is an
    error naming both files.
    """
    files: list[Path] = []
    for entry in map(Path, paths):
        if entry.is_dir():
            files.extend(sorted(entry.glob("*.toml"), key=lambda p: p.name))
        else:
            files.append(entry)
    walls: dict[str, Wall] = {}
    errors: list[str] = []
    for file in files:
        try:
            wall = load_wall(file)
        except WallConfigError as error:
            errors.extend(error.errors)
            continue
        if wall.id in walls:
            first = walls[wall.id].source
            errors.append(f"{file}: id: duplicate wall id {wall.id!r} (also in {first})")
            continue
        walls[wall.id] = wall
    if errors:
        raise WallConfigError(errors)
    return walls
