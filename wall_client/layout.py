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

Walls are read from TOML configs by ``wall_client.config``; docs/wall-config.md
documents every key.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Literal
from zoneinfo import ZoneInfo

BezelMode = Literal["overlay", "offset"]
CodePurpose = Literal["walk-up", "seat"]
Rotation = Literal[0, 90, 180, 270]
ROLES: tuple[str, ...] = ("public", "menu", "registration")

# An affine map (a, b, c, d, e, f) as in CSS/canvas ``setTransform``:
# x' = a*x + c*y + e ; y' = b*x + d*y + f
Affine = tuple[float, float, float, float, float, float]

IDENTITY: Affine = (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
ROTATIONS: tuple[int, ...] = (0, 90, 180, 270)

DEFAULT_WALK_UP_DISTANCE_M = 0.8
STAGE_ASPECT = (4, 3)  # the picture the default stage is chosen for: a bit wider than tall


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

    def overlap(self, other: Rect) -> tuple[float, float]:
        """Width and height of the common part (zero or negative when there is none)."""
        return (
            min(self.right, other.right) - max(self.x, other.x),
            min(self.bottom, other.bottom) - max(self.y, other.y),
        )

    def intersects(self, other: Rect) -> bool:
        """True when the two overlap with positive area; touching edges do not count."""
        overlap_w, overlap_h = self.overlap(other)
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


def mounted_size(resolution: tuple[int, int], rotation: int) -> tuple[int, int]:
    """A panel's pixels along the wall's x and y axes: swapped when turned a quarter."""
    w, h = resolution
    return (h, w) if rotation in (90, 270) else (w, h)


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
        return mounted_size(self.resolution, self.rotation)

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
    time_zone: str = "UTC"  # an IANA name: the times people read (exports, the dashboard)
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

    def local_time(self, when: datetime) -> datetime:
        """``when`` (an aware time) as people at the wall read it: in its time zone."""
        return when.astimezone(ZoneInfo(self.time_zone))

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
                    picture = min(area.width / STAGE_ASPECT[0], area.height / STAGE_ASPECT[1])
                    score = (picture, area.width * area.height, -y0, -x0)
                    if best is not None and score <= best:
                        continue  # cannot win: spare the overlap and containment tests
                    if any(area.intersects(r) for r in designated):
                        break  # a taller rectangle from the same top overlaps too
                    inside = tuple(d.id for d in free if area.contains(d.rect))
                    if inside:
                        best, chosen = score, inside
    return chosen or tuple(d.id for d in free)
