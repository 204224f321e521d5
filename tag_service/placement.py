"""Placing codes on the wall canvas so every one of them can be scanned.

Rules, in scene millimetres (the wall canvas; physical wall mm in overlay mode):

* a code lies wholly inside one display (never across a bezel or a gap), on that
  display's pixel grid, with whole pixels per module (see :mod:`tag_service.sizing`);
* it overlaps no other code and no reserved rectangle (touching is fine: the quiet
  zone is part of the code);
* a code with a caption (its label) has the caption's strip reserved under it, on the
  same display: a caption is never cut by a display edge and never overlaps another
  code or caption. Anchored codes keep a gap of :data:`SPREAD_OF_SIDE` code sides
  from each other, so neighbouring codes read as separate things;
* pins never cross, so every head can be traced to its code: no pin crosses another
  (they meet at most at a head they share), runs under a code or caption, or passes
  through another tag's anchor, and no code or caption covers another tag's anchor
  (every anchor of the layout, placed yet or not: its pin head goes there). A spot that
  would break this is skipped (:func:`clashes` is the predicate; :func:`pin_conflicts`
  reports a finished layout's breaches with it);
* an anchored code never stands on a designated screen (public, menu, registration:
  those show panels) and stands as near its anchor as possible, at most
  ``max_offset_codes`` code sides plus its clearance (``clear_mm``) away, centre to
  anchor; a displaced code gets a leader line (pin) from its edge to the anchor;
* an anchored request with a clearance (``clear_mm > 0``) keeps the square of side
  ``2 * clear_mm`` centred on its anchor free of anchored codes, its own and every
  other: all those squares are reserved before the first anchored code is placed, so
  no code hides the point it marks nor another tag's pin head. Its code stands
  nearest outside the square and always gets a pin. Adding the clearance to the reach
  keeps such a code placeable: a code right beside the square is ``clear_mm`` plus
  half a side from the anchor. The squares do not apply to slot codes: those stand
  on designated screens (panels, where no anchored code stands) and are placed
  first, so a tag's clearance never moves a panel's codes;
* a slot code stands in its cell of a grid laid over its screen's displays;
* every request ends up placed or unplaced with the reason, never dropped; the
  result depends only on the inputs (slot codes first, then the clear squares, then
  anchored codes in the order given).

The nearest free position is exact: with rectangular obstacles, the best top-left
corner has each coordinate either where the anchor wants it or flush against an
obstacle or display edge, so those candidates are searched (vectorised per display).
Pins are lines, not rectangles: among those candidates, the nearest whose pin keeps
the rule wins (asked nearest first, a few at a time), which is not always the nearest
spot that would keep it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Literal, NamedTuple

import numpy as np
import numpy.typing as npt

from tag_service.sizing import CodeSize, code_size
from wall_client.layout import ROLES, Display, Rect, Wall

CAPTION_OF_SIDE = 0.2
"""A caption strip's height, in code sides (its text fills most of it)."""
SLOT_CAPTION_OF_SIDE = 2.0
"""How wide a slot code's caption may be, in code sides (within its cell): menu labels
run longer than tract numbers."""
SPREAD_OF_SIDE = 0.25
"""The gap kept between anchored codes (and their captions), in code sides."""

Point = tuple[float, float]
Ints = npt.NDArray[np.int64]
Floats = npt.NDArray[np.float64]
Bools = npt.NDArray[np.bool_]
Box = tuple[int, int, int, int]  # x0, y0, x1, y1 in a display's pixels (as mounted)
Accept = Callable[[Floats, Floats], Bools]
"""Which candidate boxes (rows x0, y0, x1, y1, scene mm) may stand, given each box's
point nearest the anchor (rows x, y: where a pin or pointer leaves it)."""
ACCEPT_CHUNK = 16
"""How many of the nearest spots an :data:`Accept` rule is first asked about (then four
times as many at a time): the nearest usually passes."""


@dataclass(frozen=True)
class PlacementRequest:
    key: str  # the tag's code
    sizes: tuple[int, ...]  # symbol widths in modules incl. quiet zone, preferred first
    module_mm: float  # the smallest physical module that scans (sizing.min_module_mm)
    anchor: Point | None = None  # scene mm
    screen: str | None = None  # a screen role, for slot requests
    slot: int = 0
    preferred_mm: float | None = None
    clear_mm: float = 0.0  # half the side of the square around the anchor kept free of codes
    caption: bool = False  # the code's label stands under it

    def __post_init__(self) -> None:
        if (self.anchor is None) == (self.screen is None):
            raise ValueError(f"{self.key}: give either an anchor or a screen slot")
        if self.screen is not None and self.screen not in ROLES:
            raise ValueError(f"{self.key}: unknown screen {self.screen!r} (roles: {ROLES})")
        if not self.sizes or min(self.sizes) < 1:
            raise ValueError(f"{self.key}: sizes must be positive module counts")
        if self.module_mm <= 0:
            raise ValueError(f"{self.key}: module_mm must be positive")
        if not (math.isfinite(self.clear_mm) and self.clear_mm >= 0):
            raise ValueError(f"{self.key}: clear_mm must be a finite distance >= 0")
        if self.clear_mm > 0 and self.anchor is None:
            raise ValueError(f"{self.key}: clear_mm needs an anchor (slot codes have none)")


@dataclass(frozen=True)
class Placement:
    key: str
    display_id: str
    rect: Rect  # scene mm, on the display's pixel grid
    pixels: tuple[int, int, int]  # x, y, side in the display's pixels (origin: its top-left)
    px_per_module: int
    modules: int
    variant: int  # index into the request's sizes
    leader: tuple[Point, Point] | None  # from the edge of code and caption to the anchor
    caption: Rect | None = None  # scene mm, under the code, on the display's pixel grid
    caption_pixels: tuple[int, int, int, int] | None = None  # x, y, width, height

    @property
    def footprint(self) -> Rect:
        """The code with its caption: what nothing else may overlap."""
        if self.caption is None:
            return self.rect
        x0, y0 = min(self.rect.x, self.caption.x), self.rect.y
        x1 = max(self.rect.right, self.caption.right)
        return Rect(x0, y0, x1 - x0, self.caption.bottom - y0)


@dataclass(frozen=True)
class Unplaced:
    key: str
    reason: str


@dataclass(frozen=True)
class Layout:
    placed: tuple[Placement, ...]
    unplaced: tuple[Unplaced, ...]


class _Canvas:
    """One display's pixel grid and what already occupies it."""

    def __init__(self, wall: Wall, display: Display) -> None:
        self.display = display
        self.rect = wall.viewport(display.id).scene_rect
        self.pw, self.ph = display.mounted_resolution
        self.sx = self.rect.width / self.pw
        self.sy = self.rect.height / self.ph
        self.boxes: list[Box] = []
        # Boxes are only ever added, so once no spot fits a side, none fits a larger one
        # (per caption kind: none, or as wide as the code).
        self.no_room_from = {False: min(self.pw, self.ph) + 1, True: min(self.pw, self.ph) + 1}
        self._sizes: dict[tuple[int, float, float | None], CodeSize] = {}

    def size(self, request: PlacementRequest, modules: int) -> CodeSize:
        """The code of ``modules`` across that ``request`` needs here (memoised)."""
        key = (modules, request.module_mm, request.preferred_mm)
        if key not in self._sizes:
            self._sizes[key] = code_size(
                self.display, modules, request.module_mm, request.preferred_mm
            )
        return self._sizes[key]

    def reserve(self, area: Rect) -> None:
        if not self.rect.intersects(area):
            return
        self.boxes.append(
            (
                max(0, math.floor((area.x - self.rect.x) / self.sx)),
                max(0, math.floor((area.y - self.rect.y) / self.sy)),
                min(self.pw, math.ceil((area.right - self.rect.x) / self.sx)),
                min(self.ph, math.ceil((area.bottom - self.rect.y) / self.sy)),
            )
        )

    def to_scene(self, x: int, y: int, side: int) -> Rect:
        return Rect(
            self.rect.x + x * self.sx, self.rect.y + y * self.sy, side * self.sx, side * self.sy
        )

    def free_spots(
        self, anchor: Point, width: int, height: int, centre_y: float
    ) -> tuple[Ints, Ints]:
        """Top-left corners where a ``width`` x ``height`` px box overlaps nothing here:
        those worth trying for the box point ``centre_y`` px below its top (centred
        horizontally) nearest ``anchor`` (empty arrays when the box fits nowhere)."""
        if width > self.pw or height > self.ph:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty
        ax, ay = anchor
        ideal_x = (ax - self.rect.x) / self.sx - width / 2
        ideal_y = (ay - self.rect.y) / self.sy - centre_y
        boxes = np.array(self.boxes, dtype=np.int64).reshape(-1, 4)
        xs = _candidates(ideal_x, boxes[:, 0], boxes[:, 2], width, self.pw)
        ys = _candidates(ideal_y, boxes[:, 1], boxes[:, 3], height, self.ph)
        grid_x, grid_y = (a.ravel() for a in np.meshgrid(xs, ys))
        if len(boxes):
            overlap = (
                (grid_x[:, None] < boxes[:, 2])
                & (grid_x[:, None] + width > boxes[:, 0])
                & (grid_y[:, None] < boxes[:, 3])
                & (grid_y[:, None] + height > boxes[:, 1])
            ).any(axis=1)
            grid_x, grid_y = grid_x[~overlap], grid_y[~overlap]
        return grid_x, grid_y

    def pick(
        self,
        anchor: Point,
        spots: tuple[Ints, Ints],
        width: int,
        height: int,
        centre_y: float,
        accept: Accept | None = None,
        within: float = math.inf,
    ) -> tuple[float, int, int] | None:
        """The spot of ``spots`` whose box point ``centre_y`` px below its top is
        nearest ``anchor`` (ties: topmost, then leftmost), at most ``within`` mm away,
        that ``accept`` takes: its distance in mm and top-left corner. ``accept`` sees
        the boxes in scene mm and each box's point nearest ``anchor`` (where its pin or
        pointer starts); it is asked about the nearest spots first, a few at a time, so
        a costly rule only looks at the spots that could win."""
        grid_x, grid_y = spots
        ax, ay = anchor
        distance = np.hypot(
            self.rect.x + (grid_x + width / 2) * self.sx - ax,
            self.rect.y + (grid_y + centre_y) * self.sy - ay,
        )
        near = distance <= within
        grid_x, grid_y, distance = grid_x[near], grid_y[near], distance[near]
        order = np.lexsort((grid_x, grid_y, distance))
        start, chunk = 0, ACCEPT_CHUNK
        while start < len(order):
            index = order[start : start + chunk]
            x0 = self.rect.x + grid_x[index] * self.sx
            y0 = self.rect.y + grid_y[index] * self.sy
            x1, y1 = x0 + width * self.sx, y0 + height * self.sy
            if accept is None:
                taken = np.ones(len(index), dtype=bool)
            else:
                edges = np.column_stack((np.clip(ax, x0, x1), np.clip(ay, y0, y1)))
                taken = accept(np.column_stack((x0, y0, x1, y1)), edges)
            if taken.any():
                best = index[int(np.argmax(taken))]
                return float(distance[best]), int(grid_x[best]), int(grid_y[best])
            start, chunk = start + chunk, chunk * 4
        return None

    def nearest(
        self,
        anchor: Point,
        width: int,
        height: int,
        centre_y: float | None = None,
        accept: Accept | None = None,
    ) -> tuple[float, int, int] | None:
        """The free spot for a ``width`` x ``height`` px box whose point ``centre_y`` px
        below its top edge, horizontally centred (default: the box's centre), is
        nearest ``anchor`` among those ``accept`` takes (see :meth:`pick`)."""
        cy = height / 2 if centre_y is None else centre_y
        spots = self.free_spots(anchor, width, height, cy)
        return self.pick(anchor, spots, width, height, cy, accept)

    def nearest_code(
        self,
        anchor: Point,
        side: int,
        caption_width: int | None,
        *,
        centre_box: bool = False,
        accept: Accept | None = None,
        within: float = math.inf,
    ) -> tuple[float, int, int] | None:
        """The free spot for a ``side`` px code (with its caption strip under it when
        ``caption_width`` is given) whose centre (or, with ``centre_box``, the centre
        of code and caption together) is nearest ``anchor``, at most ``within`` mm
        away, that ``accept`` takes: the box's top-left."""
        monotone = caption_width in (None, side)
        kind = caption_width is not None
        if monotone and side >= self.no_room_from[kind]:
            return None
        width, height = _box(side, caption_width)
        cy = height / 2 if centre_box else side / 2
        spots = self.free_spots(anchor, width, height, cy)
        if not len(spots[0]):
            # only a full canvas says so: a spot ``accept`` refuses is refused for one
            # anchor, and another anchor may still take it
            if monotone:
                self.no_room_from[kind] = side
            return None
        return self.pick(anchor, spots, width, height, cy, accept, within)


def caption_height(side: int) -> int:
    """The caption strip under a ``side`` px code, in pixels."""
    return max(1, math.ceil(side * CAPTION_OF_SIDE))


def _box(side: int, caption_width: int | None) -> tuple[int, int]:
    """Width and height of a code with its caption (``None``: no caption)."""
    if caption_width is None:
        return side, side
    return max(side, caption_width), side + caption_height(side)


def _candidates(ideal: float, starts: Ints, ends: Ints, side: int, extent: int) -> Ints:
    """Top-left coordinates worth trying along one axis."""
    values = np.concatenate(([round(ideal), 0, extent - side], ends, starts - side))
    return np.unique(np.clip(values, 0, extent - side))


def place(
    wall: Wall,
    requests: Sequence[PlacementRequest],
    reserved: Sequence[Rect] = (),
    *,
    max_offset_codes: float = 3.0,
) -> Layout:
    """Place ``requests`` on ``wall`` avoiding ``reserved`` rectangles (scene mm).

    An anchored code's centre stands at most ``max_offset_codes`` code sides plus
    its request's ``clear_mm`` from the anchor: straight out from a side of the clear
    square, the reach counts from that side, so a clearance never makes a code
    unplaceable that fits right beside its square (its centre is then ``clear_mm``
    plus half a side from the anchor). The distance stays the plain one from the
    anchor, so the nearest free spot is also the one to check against the reach.
    """
    keys = [request.key for request in requests]
    if len(set(keys)) != len(keys):
        raise ValueError("placement requests need unique keys")
    canvases = {d.id: _Canvas(wall, d) for d in wall.displays}
    for canvas in canvases.values():
        for area in reserved:
            canvas.reserve(area)
    outcome: dict[str, Placement | Unplaced] = {}
    slotted = [r for r in requests if r.screen is not None]
    for role in ROLES:
        on_screen = sorted((r for r in slotted if r.screen == role), key=lambda r: r.slot)
        if on_screen:
            _place_on_screen(wall, role, on_screen, canvases, outcome)
    anchored = [r for r in requests if r.anchor is not None]
    pins = _Pins([r.anchor for r in anchored if r.anchor is not None])
    for slot_code in outcome.values():
        if isinstance(slot_code, Placement):
            pins.add(slot_code)
    designated = {d.id for role in ROLES for d in wall.screen(role)}
    free = [canvases[d.id] for d in wall.displays if d.id not in designated]
    bounds = _bounds(free)
    for request in requests:  # every pin head is kept clear before any code is placed
        if request.anchor is not None and request.clear_mm > 0:
            square = _clear_square(request.anchor, request.clear_mm)
            for canvas in free:
                canvas.reserve(square)
    for index, request in enumerate(anchored):
        assert request.anchor is not None
        result = pins.hiding(request) or _place_anchored(
            request, request.anchor, free, bounds, max_offset_codes, pins.rule(index)
        )
        if isinstance(result, Placement):
            pins.add(result)
        outcome[request.key] = result
    placed = tuple(o for key in keys if isinstance(o := outcome[key], Placement))
    unplaced = tuple(o for key in keys if isinstance(o := outcome[key], Unplaced))
    return Layout(placed, unplaced)


def place_box(
    wall: Wall,
    size_mm: tuple[float, float],
    anchor: Point,
    obstacles: Sequence[Rect],
    clear_mm: float = 0.0,
    sight: Sequence[Rect] | None = None,
    on: Sequence[str] | None = None,
) -> Rect | None:
    """Where a box of ``size_mm`` (a description balloon, a legend) stands nearest
    ``anchor``: wholly on one of the displays ``on`` (by default every display that is
    not a designated screen), clear of ``obstacles`` (codes with their captions, other
    boxes) and of the square of side ``2 * clear_mm`` around ``anchor``. With
    ``sight``, its pointer (the straight line from the box's nearest point to
    ``anchor``) also crosses none of those rectangles: the nearest such spot among
    those flush with obstacles and display edges. None when no display has room."""
    allowed = set(on) if on is not None else {d.id for d in wall.displays} - wall.designated()
    accept: Accept | None = None
    if sight is not None:
        seen = _rows(sight)
        target = np.array(anchor, dtype=np.float64)

        def accept(boxes: Floats, edges: Floats) -> Bools:
            return ~_crosses(edges, np.broadcast_to(target, edges.shape), seen)

    best: tuple[float, Rect] | None = None
    for display in wall.displays:
        if display.id not in allowed:
            continue
        canvas = _Canvas(wall, display)
        for area in obstacles:
            canvas.reserve(area)
        if clear_mm > 0:
            canvas.reserve(_clear_square(anchor, clear_mm))
        width = math.ceil(size_mm[0] / canvas.sx)
        height = math.ceil(size_mm[1] / canvas.sy)
        spot = canvas.nearest(anchor, width, height, accept=accept)
        if spot is not None and (best is None or spot[0] < best[0]):
            distance, x, y = spot
            box = Rect(
                canvas.rect.x + x * canvas.sx,
                canvas.rect.y + y * canvas.sy,
                width * canvas.sx,
                height * canvas.sy,
            )
            best = (distance, box)
    return best[1] if best else None


def _crosses(starts: Floats, ends: Floats, rects: Floats) -> Bools:
    """Which segments ``starts[i] -> ends[i]`` (n, 2) pass through the inside of any of
    ``rects`` (m, 4: x0, y0, x1, y1)."""
    return np.asarray(_through(starts, ends, rects).any(axis=1), dtype=bool)


def _through(starts: Floats, ends: Floats, rects: Floats) -> Bools:
    """(n, m): whether segment ``starts[i] -> ends[i]`` passes through the inside of
    ``rects[j]``; running along an edge or touching a corner does not count, nor does a
    segment with a NaN coordinate (the slab method, all pairs at once)."""
    if not len(rects) or not len(starts):
        return np.zeros((len(starts), len(rects)), dtype=bool)
    origin = starts[:, None, :]  # (n, 1, 2)
    delta = (ends - starts)[:, None, :]
    low, high = rects[None, :, :2], rects[None, :, 2:]  # (1, m, 2)
    tiny = 1e-9
    flat = np.abs(delta) < tiny
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (low - origin) / np.where(flat, 1.0, delta)
        t2 = (high - origin) / np.where(flat, 1.0, delta)
    inside = (origin > low + tiny) & (origin < high - tiny)  # a flat axis must lie within
    enter = np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2)).max(axis=2)
    leave = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2)).min(axis=2)
    crossing: Bools = (enter < leave - tiny) & (leave > tiny) & (enter < 1 - tiny)
    return crossing


def _segments_cross(a: Floats, b: Floats) -> Bools:
    """(n, m): whether segment ``a[i]`` meets segment ``b[j]`` (rows x0, y0, x1, y1)
    anywhere but at an end they share: crossing, one ending on the other's line, or
    both running along the same line. Pins that only share their head (two tags
    marking the same point) do not count; nor does a NaN row or a point."""
    if not len(a) or not len(b):
        return np.zeros((len(a), len(b)), dtype=bool)
    tiny = 1e-9
    r = (a[:, 2:] - a[:, :2])[:, None, :]
    s = (b[:, 2:] - b[:, :2])[None, :, :]
    qp = b[None, :, :2] - a[:, None, :2]  # from a's start to b's start

    def side(u: Floats, v: Floats) -> Floats:
        """The sign of the cross product u x v: which side of u the point v is on."""
        product = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
        sign: Floats = (product > tiny).astype(np.float64) - (product < -tiny)
        return sign

    b0, b1 = side(r, qp), side(r, qp + s)  # b's ends against a's line
    a0, a1 = side(s, -qp), side(s, r - qp)  # a's ends against b's line
    meet = (b0 * b1 <= 0) & (a0 * a1 <= 0)
    in_line = (b0 == 0) & (b1 == 0) & (a0 == 0) & (a1 == 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        length2 = (r * r).sum(axis=-1)
        t0 = (qp * r).sum(axis=-1) / length2  # b's ends along a (a from 0 to 1)
        t1 = ((qp + s) * r).sum(axis=-1) / length2
    overlap = np.minimum(np.maximum(t0, t1), 1.0) - np.maximum(np.minimum(t0, t1), 0.0) > tiny
    shared = np.zeros(meet.shape, dtype=bool)
    for offset in (qp, qp + s, qp - r, qp + s - r):  # b's ends from a's ends
        shared |= (offset * offset).sum(axis=-1) < tiny
    crossing: Bools = np.where(in_line, overlap, meet & ~shared)
    return crossing


def _passes(segments: Floats, points: Floats) -> Bools:
    """(n, m): whether segment ``segments[i]`` (x0, y0, x1, y1) passes through
    ``points[j]`` anywhere but at its end (x1, y1): a pin through another tag's head."""
    if not len(segments) or not len(points):
        return np.zeros((len(segments), len(points)), dtype=bool)
    tiny = 1e-12
    start, delta = segments[:, None, :2], (segments[:, 2:] - segments[:, :2])[:, None, :]
    offset = points[None, :, :] - start
    t = np.clip((offset * delta).sum(axis=-1) / np.maximum((delta**2).sum(axis=-1), tiny), 0, 1)
    miss = offset - t[..., None] * delta
    away = offset - delta  # from the segment's end
    result: Bools = ((miss * miss).sum(axis=-1) < tiny) & ((away * away).sum(axis=-1) >= tiny)
    return result


def _inside(points: Floats, rects: Floats) -> Bools:
    """(n, m): whether ``points[i]`` (x, y) lies strictly inside ``rects[j]`` (on an
    edge is outside; a NaN point is inside nothing)."""
    tiny = 1e-9
    x, y = points[:, None, 0], points[:, None, 1]
    result: Bools = (
        (x > rects[None, :, 0] + tiny)
        & (x < rects[None, :, 2] - tiny)
        & (y > rects[None, :, 1] + tiny)
        & (y < rects[None, :, 3] - tiny)
    )
    return result


class Clashes(NamedTuple):
    """What new codes with their pins would do to the ones already standing (n new,
    k standing codes, m standing pins): the rule "pins never cross" in full."""

    crossing: Bools  # (n, m) the new pin crosses a standing pin
    pin_under: Bools  # (n, k) the new pin runs under a standing code or caption
    under_pin: Bools  # (n, m) a standing pin runs under the new code or caption
    head_under: Bools  # (n, k) the new pin's head lies under a standing code or caption
    covers_head: Bools  # (n, m) the new code or caption covers a standing pin's head

    def any(self) -> Bools:
        """(n,): which new codes break the rule at all."""
        result: Bools = np.zeros(len(self.crossing), dtype=bool)
        for matrix in self:
            result = result | np.asarray(matrix.any(axis=1), dtype=bool)
        return result


def clashes(codes: Floats, pins: Floats, footprints: Floats, leaders: Floats) -> Clashes:
    """The one predicate for pins: new codes ``codes`` (n, 4: x0, y0, x1, y1, code with
    caption) with their pins ``pins`` (n, 4: from the code's edge x0, y0 to the head
    x1, y1; a NaN row for a code without a pin) against the codes ``footprints``
    (k, 4) and pins ``leaders`` (m, 4) already standing. Placement refuses a spot that
    clashes; :func:`pin_conflicts` reports a finished layout's clashes."""
    heads = leaders[:, 2:]
    return Clashes(
        crossing=_segments_cross(pins, leaders),
        pin_under=_through(pins[:, :2], pins[:, 2:], footprints),
        under_pin=_through(leaders[:, :2], leaders[:, 2:], codes).T,
        head_under=_inside(pins[:, 2:], footprints),
        covers_head=_inside(heads, codes).T,
    )


ConflictKind = Literal["crossing", "pin under code", "head under code"]


@dataclass(frozen=True)
class Mark:
    """What a placed code draws that the pin rule looks at (scene mm)."""

    key: str
    footprint: Rect  # the code with its caption
    leader: tuple[Point, Point] | None  # its pin: from the footprint's edge to the head


@dataclass(frozen=True)
class PinConflict:
    kind: ConflictKind
    pin: str  # the key whose pin (line or head) is crossed or hidden
    other: str  # the key whose pin crosses it, or whose code hides it

    def __str__(self) -> str:
        if self.kind == "crossing":
            return f"the pins of {self.pin} and {self.other} cross"
        if self.kind == "pin under code":
            return f"the pin of {self.pin} runs under the code of {self.other}"
        return f"the pin head of {self.pin} lies under the code of {self.other}"


def pin_conflicts(marks: Sequence[Mark]) -> list[PinConflict]:
    """Every way ``marks`` break the pin rule (see :func:`clashes`): pins that cross,
    pins that run under a code or caption, pin heads under a code or caption. Each
    mark is held against the ones before it, as placement held it when it stood."""
    found: list[PinConflict] = []
    for index, mark in enumerate(marks):
        before = marks[:index]
        pinned = [m for m in before if m.leader is not None]
        footprints = _rows([m.footprint for m in before])
        leaders = _leader_rows([m.leader for m in pinned])
        clash = clashes(_rows([mark.footprint]), _leader_rows([mark.leader]), footprints, leaders)
        for j in np.flatnonzero(clash.crossing[0]).tolist():
            found.append(PinConflict("crossing", pinned[j].key, mark.key))
        for j in np.flatnonzero(clash.pin_under[0]).tolist():
            found.append(PinConflict("pin under code", mark.key, before[j].key))
        for j in np.flatnonzero(clash.under_pin[0]).tolist():
            found.append(PinConflict("pin under code", pinned[j].key, mark.key))
        for j in np.flatnonzero(clash.head_under[0]).tolist():
            found.append(PinConflict("head under code", mark.key, before[j].key))
        for j in np.flatnonzero(clash.covers_head[0]).tolist():
            found.append(PinConflict("head under code", pinned[j].key, mark.key))
    return found


def marks_of(layout: Layout) -> list[Mark]:
    """The marks of a layout's placed codes."""
    return [Mark(p.key, p.footprint, p.leader) for p in layout.placed]


def _rows(rects: Sequence[Rect]) -> Floats:
    """Rectangles as rows x0, y0, x1, y1."""
    rows = [(r.x, r.y, r.right, r.bottom) for r in rects]
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def _leader_rows(leaders: Sequence[tuple[Point, Point] | None]) -> Floats:
    """Pins as rows x0, y0, x1, y1 (from the code to the head; NaN for none)."""
    nan = (math.nan, math.nan)
    rows = [(*start, *end) for start, end in (leader or (nan, nan) for leader in leaders)]
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


class _Pins:
    """The codes and pins standing so far, and every anchor of the layout: what a new
    anchored code's spot is held against (:func:`clashes`, and no code or caption over
    another tag's anchor, whether that tag stands yet or not: its pin head goes there)."""

    def __init__(self, anchors: Sequence[Point]) -> None:
        self.anchors = np.array(anchors, dtype=np.float64).reshape(-1, 2)
        self.footprints = np.zeros((0, 4))
        self.leaders = np.zeros((0, 4))

    def add(self, placement: Placement) -> None:
        self.footprints = np.vstack((self.footprints, _rows([placement.footprint])))
        if placement.leader is not None:
            self.leaders = np.vstack((self.leaders, _leader_rows([placement.leader])))

    def hiding(self, request: PlacementRequest) -> Unplaced | None:
        """Why ``request`` cannot stand when a code already standing (a slot code: its
        panel's screen also shows the scene) hides its anchor, where its head would go."""
        assert request.anchor is not None
        point = np.array([request.anchor], dtype=np.float64)
        if not _inside(point, self.footprints).any():
            return None
        x, y = request.anchor
        return Unplaced(request.key, f"its anchor ({x:.1f}, {y:.1f}) lies under another code")

    def rule(self, index: int) -> _Rule:
        """The rule for the code of ``anchors[index]`` (see :class:`_Rule`)."""
        return _Rule(self, index)


class _Rule:
    """Where the code of one anchor may stand: its spot clashes with nothing standing
    (:func:`clashes`), and neither its code nor its pin covers another anchor (a head
    that may yet come: a later pin could not reach it). Counts the spots it refuses,
    so an unplaced code says why."""

    def __init__(self, pins: _Pins, index: int) -> None:
        self.pins = pins
        self.head = pins.anchors[index]
        self.others = np.delete(pins.anchors, index, axis=0)
        self.refused = 0

    def __call__(self, boxes: Floats, edges: Floats) -> Bools:
        # Only what reaches into the extent of these boxes and their pins can clash
        # with them: the rest of the wall is left out before the pairwise tests.
        low = np.minimum(boxes[:, :2].min(axis=0), self.head)
        high = np.maximum(boxes[:, 2:].max(axis=0), self.head)
        footprints = self.pins.footprints[_meets(self.pins.footprints, low, high)]
        leaders = self.pins.leaders
        spans = np.column_stack(
            (np.minimum(leaders[:, :2], leaders[:, 2:]), np.maximum(leaders[:, :2], leaders[:, 2:]))
        )
        leaders = leaders[_meets(spans, low, high)]
        others = self.others[((self.others >= low) & (self.others <= high)).all(axis=1)]
        if not (len(footprints) or len(leaders) or len(others)):
            return np.ones(len(boxes), dtype=bool)
        lines = np.column_stack((edges, np.broadcast_to(self.head, edges.shape)))
        clash = clashes(boxes, lines, footprints, leaders)
        hidden = _inside(others, boxes).any(axis=0)
        bad = clash.any() | hidden | _passes(lines, others).any(axis=1)
        self.refused += int(bad.sum())
        return ~bad


def _meets(rects: Floats, low: Floats, high: Floats) -> Bools:
    """Which ``rects`` (rows x0, y0, x1, y1) reach into the box ``low``-``high``
    (touching counts)."""
    result: Bools = (
        (rects[:, 0] <= high[0])
        & (rects[:, 2] >= low[0])
        & (rects[:, 1] <= high[1])
        & (rects[:, 3] >= low[1])
    )
    return result


def _place_anchored(
    request: PlacementRequest,
    anchor: Point,
    canvases: list[_Canvas],
    bounds: Floats,
    max_offset_codes: float,
    rule: _Rule,
) -> Placement | Unplaced:
    gaps = _distances(anchor, bounds)
    by_distance = [(float(gaps[i]), canvases[i]) for i in np.argsort(gaps, kind="stable")]
    smallest_side: tuple[float, int] | None = None
    reach = 0.0
    for variant, modules in enumerate(request.sizes):
        best: tuple[float, _Canvas, int, int, int, int] | None = None
        for gap, canvas in by_distance:
            if best is not None and gap > best[0]:
                break
            size = canvas.size(request, modules)
            side_mm = size.side_px * canvas.sx
            if smallest_side is None or side_mm < smallest_side[0]:
                smallest_side = (side_mm, size.side_px)
            limit = max_offset_codes * side_mm + request.clear_mm
            reach = max(reach, limit)
            if gap > limit:
                continue
            caption = size.side_px if request.caption else None
            spot = canvas.nearest_code(anchor, size.side_px, caption, accept=rule, within=limit)
            if spot is None:
                continue
            if best is None or spot[0] < best[0]:
                best = (spot[0], canvas, spot[1], spot[2], size.side_px, size.px_per_module)
        if best is not None:
            _, canvas, x, y, side, ppm = best
            caption = side if request.caption else None
            placed = _commit(request, canvas, (x, y), side, caption, ppm, modules, variant, anchor)
            gap = math.ceil(side * SPREAD_OF_SIDE)
            x0, y0, x1, y1 = canvas.boxes[-1]
            canvas.boxes[-1] = (x0 - gap, y0 - gap, x1 + gap, y1 + gap)
            return placed
    if smallest_side is not None and all(
        c.size(request, m).side_px > min(c.pw, c.ph) for c in canvases for m in request.sizes
    ):
        side_mm, side_px = smallest_side
        return Unplaced(
            request.key, f"display too small for a {side_mm:.0f} mm code (needs {side_px} px)"
        )
    ax, ay = anchor
    where = f"no space within {reach:.0f} mm of the anchor ({ax:.1f}, {ay:.1f})"
    if rule.refused:
        where += " where its pin crosses no pin or code and its code hides no pin head"
    return Unplaced(request.key, where)


def _place_on_screen(
    wall: Wall,
    role: str,
    requests: list[PlacementRequest],
    canvases: dict[str, _Canvas],
    outcome: dict[str, Placement | Unplaced],
) -> None:
    displays = wall.screen(role)
    if not displays:
        for request in requests:
            outcome[request.key] = Unplaced(request.key, f"wall has no {role!r} screen")
        return
    per_display = math.ceil(len(requests) / len(displays))
    for index, display in enumerate(displays):
        chunk = requests[index * per_display : (index + 1) * per_display]
        if not chunk:
            break
        canvas = canvases[display.id]
        centres, cell_width = _cells(canvas.rect, len(chunk))
        for request, anchor in zip(chunk, centres, strict=True):
            outcome[request.key] = _place_in_cell(
                request, anchor, math.floor(cell_width / canvas.sx), canvas, role, len(chunk)
            )


def _place_in_cell(
    request: PlacementRequest,
    anchor: Point,
    cell_px: int,
    canvas: _Canvas,
    role: str,
    count: int,
) -> Placement | Unplaced:
    """A slot code in its cell: its caption as wide as the cell allows (up to
    :data:`SLOT_CAPTION_OF_SIDE` code sides), never narrower than the code."""
    side_mm = 0.0
    for variant, modules in enumerate(request.sizes):
        size = canvas.size(request, modules)
        side = size.side_px
        side_mm = side_mm or side * canvas.sx
        caption = (
            max(side, min(cell_px, math.floor(side * SLOT_CAPTION_OF_SIDE)))
            if request.caption
            else None
        )
        spot = canvas.nearest_code(anchor, side, caption, centre_box=True)
        if spot is not None:
            _, x, y = spot
            return _commit(
                request, canvas, (x, y), side, caption, size.px_per_module, modules, variant, None
            )
    return Unplaced(
        request.key,
        f"the {role} screen ({canvas.display.id}) has no room for"
        f" {count} codes of {side_mm:.0f} mm with their captions",
    )


def _cells(rect: Rect, count: int) -> tuple[list[Point], float]:
    """Centres of ``count`` near-square cells filling ``rect`` in reading order, and
    the cells' width."""
    columns = max(1, math.ceil(math.sqrt(count * rect.width / rect.height)))
    columns = min(columns, count)
    rows = math.ceil(count / columns)
    width, height = rect.width / columns, rect.height / rows
    centres = [
        (rect.x + (i % columns + 0.5) * width, rect.y + (i // columns + 0.5) * height)
        for i in range(count)
    ]
    return centres, width


def _commit(
    request: PlacementRequest,
    canvas: _Canvas,
    box: tuple[int, int],
    side: int,
    caption_width: int | None,
    ppm: int,
    modules: int,
    variant: int,
    anchor: Point | None,
) -> Placement:
    """Take the spot: the code at the top of its box, centred, its caption under it."""
    width, height = _box(side, caption_width)
    bx, by = box
    canvas.boxes.append((bx, by, bx + width, by + height))
    x = bx + (width - side) // 2
    rect = canvas.to_scene(x, by, side)
    caption = caption_pixels = None
    if caption_width is not None:
        caption_pixels = (
            bx + (width - caption_width) // 2,
            by + side,
            caption_width,
            height - side,
        )
        cx, cy, cw, ch = caption_pixels
        caption = Rect(
            canvas.rect.x + cx * canvas.sx,
            canvas.rect.y + cy * canvas.sy,
            cw * canvas.sx,
            ch * canvas.sy,
        )
    placement = Placement(
        key=request.key,
        display_id=canvas.display.id,
        rect=rect,
        pixels=(x, by, side),
        px_per_module=ppm,
        modules=modules,
        variant=variant,
        leader=None,
        caption=caption,
        caption_pixels=caption_pixels,
    )
    footprint = placement.footprint
    if anchor is not None and (request.clear_mm > 0 or not footprint.contains(anchor)):
        edge = (
            min(max(anchor[0], footprint.x), footprint.right),
            min(max(anchor[1], footprint.y), footprint.bottom),
        )
        return replace(placement, leader=(edge, anchor))
    return placement


def _clear_square(anchor: Point, clear_mm: float) -> Rect:
    """The square of side ``2 * clear_mm`` centred on ``anchor`` (scene mm)."""
    return Rect(anchor[0] - clear_mm, anchor[1] - clear_mm, 2 * clear_mm, 2 * clear_mm)


def _bounds(canvases: Sequence[_Canvas]) -> Floats:
    """Each canvas as a row ``x0, y0, x1, y1`` (scene mm)."""
    rows = [(c.rect.x, c.rect.y, c.rect.right, c.rect.bottom) for c in canvases]
    return np.array(rows, dtype=np.float64).reshape(-1, 4)


def _distances(point: Point, bounds: Floats) -> Floats:
    """How far ``point`` is from each rectangle of ``bounds`` (0 inside it)."""
    x, y = point
    dx = np.maximum(np.maximum(bounds[:, 0] - x, x - bounds[:, 2]), 0.0)
    dy = np.maximum(np.maximum(bounds[:, 1] - y, y - bounds[:, 3]), 0.0)
    distance: Floats = np.hypot(dx, dy)
    return distance
