"""The census map on the wall: where tracts fall for a view, which can carry a code,
and one tile's share of the map.

Tracts are put once on a flat plane (x = longitude · cos φ0, y = -latitude, φ0 the
data set's middle latitude: an equirectangular projection, true to shape at the
scale of a county). The plane differs from the wall's scene only by a scale and a
shift, so a pan or zoom never redoes geometry: it changes :class:`Projection`.
At the whole-map view the data is as large as its shape allows on the displays that
show the map (:meth:`MapGeometry.fit`), once per data set and wall.
Outlines are simplified at a few tolerances, each twice the one before, and each
tile takes the coarsest that stays within half a pixel of the true outline.

Codes and balloons are placed through a :class:`MapProjection`, where the map's plane
appears on the wall: the flat map's :class:`Projection`, or the globe's camera
(``globe.GlobeProjection``), so the same placement serves both.
"""

from __future__ import annotations

import itertools
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
import shapely
from shapely import MultiPolygon, Polygon
from shapely.ops import nearest_points, polylabel

from wall_client.layout import Affine, Rect, Wall, apply_affine, compose_affine
from webapp.apps.census_map.dataset import DataSet
from webapp.engine.wall_state import View

MARGIN = 0.01  # of the wall's shorter side, kept between the data and a panel or the edge
FIT_OF_EXTENT = 2.0**-9  # the fit's outline of the data strays this share of its size at most
FIT_PRECISION = 1e-3  # bisection stops this share short of the largest scale, at most
FIT_GRID = 8  # placements tried across the map's area's shorter side before refining
BEZEL_OF_DISPLAY = 0.25  # a gap between displays narrower than this share of them is a bezel
LEVELS = 8  # simplified outlines kept, each twice as coarse as the one before
FINEST_OF_EXTENT = 2.0**-16  # the finest level's tolerance, as a share of the data's size
LABEL_MM_PER_M = 6.0  # tract-number height (mm) per metre of scanning distance
OUTLINE_MM_PER_M = 0.75  # tract-outline width (mm) per metre of viewing distance: 2.6 arcmin
MIN_OUTLINE_PX = 1.5
# The map's colours, sent to tiles with their share of the map. The outline must stand
# out from the fills it separates (WCAG 2 non-text contrast: at least 3:1 against the
# tract fill and the background beyond the map); tests/webapp/apps/census_map checks it.
COLOURS = {
    "background": "#0d1b2a",
    "fill": "#523e2b",
    "outline": "#c9a46c",
    "label": "#f5e6d0",
}
CLUSTER_CELL = 1.5  # a cluster gathers the small tracts of a cell this many footprints wide
MAX_CLUSTER_TRACTS = 40  # beyond this a cluster is split in two, and again
LABEL_WIDTH_OF_HEIGHT = 0.7  # a bold digit's width in the label's height (generous)
SIMPLIFY_PX = 0.25  # simplification tolerance: outlines stay well within half a pixel
POINTER_TARGETS = 6  # the parts of a tract a balloon's pointer is tried at
Floats = npt.NDArray[np.float64]
Shapes = npt.NDArray[np.object_]


def _plane(lat0: float) -> Any:
    factor = math.cos(math.radians(lat0))

    def to_plane(coords: Floats) -> Floats:
        return np.column_stack((coords[:, 0] * factor, -coords[:, 1]))

    return to_plane


def _largest(shape: Polygon | MultiPolygon) -> Polygon:
    if isinstance(shape, Polygon):
        return shape
    return max(shape.geoms, key=lambda part: part.area)


@dataclass
class MapGeometry:
    """A data set's tracts on the plane, computed once per data set."""

    geoids: tuple[str, ...]
    shapes: Shapes  # plane units
    bounds: Floats  # (n, 4): minx, miny, maxx, maxy
    extent: tuple[float, float, float, float]
    label_points: Floats  # (n, 2): a point well inside each tract
    room: Floats  # (n,): radius of the widest circle inside the tract around that point
    lat0: float  # the plane's middle latitude (degrees): x = longitude · cos(lat0)
    _levels: dict[int, Shapes] = field(default_factory=dict, repr=False)
    _fits: dict[str, Projection] = field(default_factory=dict, repr=False)
    # Reentrant: a fit takes outlines. Held while one is made, so the tiles of a wall
    # asking at once wait for it rather than each making it.
    _lock: threading.RLock = field(default_factory=threading.RLock, repr=False)

    @classmethod
    def of(cls, dataset: DataSet) -> MapGeometry:
        shapes_ll = np.array([t.shape for t in dataset.tracts], dtype=object)
        lat0 = float(np.mean(shapely.bounds(shapes_ll)[:, [1, 3]])) if len(shapes_ll) else 0.0
        shapes = shapely.transform(shapes_ll, _plane(lat0))
        bounds = shapely.bounds(shapes)
        centres = [visual_centre(shape) for shape in shapes]
        points = [point for point, _ in centres]
        room = [radius for _, radius in centres]
        extent = (
            (
                float(bounds[:, 0].min()),
                float(bounds[:, 1].min()),
                float(bounds[:, 2].max()),
                float(bounds[:, 3].max()),
            )
            if len(bounds)
            else (0.0, 0.0, 1.0, 1.0)
        )
        return cls(
            geoids=tuple(t.geoid for t in dataset.tracts),
            shapes=shapes,
            bounds=bounds.reshape(-1, 4),
            extent=extent,
            label_points=np.array(points, dtype=np.float64).reshape(-1, 2),
            room=np.array(room, dtype=np.float64),
            lat0=lat0,
        )

    @property
    def size(self) -> float:
        minx, miny, maxx, maxy = self.extent
        return max(maxx - minx, maxy - miny, 1e-12)

    def to_lonlat(self, u: float, v: float) -> tuple[float, float]:
        """A point of the plane as longitude/latitude: the plane's projection undone."""
        return (u / math.cos(math.radians(self.lat0)), -v)

    def from_lonlat(self, longitude: float, latitude: float) -> tuple[float, float]:
        """A longitude/latitude on the plane (:meth:`to_lonlat` undone)."""
        return (longitude * math.cos(math.radians(self.lat0)), -latitude)

    def outlines(self, tolerance: float) -> Shapes:
        """Outlines simplified as much as ``tolerance`` (plane units) allows: none
        strays further than that from the true outline."""
        level = math.floor(math.log2(max(tolerance, 1e-300) / (self.size * FINEST_OF_EXTENT)))
        if level < 0:
            return self.shapes
        level = min(level, LEVELS - 1)
        with self._lock:
            if level not in self._levels:
                self._levels[level] = _simplify(
                    self.shapes, self.size * FINEST_OF_EXTENT * 2**level
                )
            return self._levels[level]

    def fit(self, wall: Wall) -> Projection:
        """The data at the whole-map view: as large as its shape allows on the displays
        that show the map (bezels between two of them count as shown), clear of the
        designated screens and the wall's edge by :data:`MARGIN`. Made once per wall
        (walls are immutable; a wall id names one) and kept."""
        with self._lock:
            if wall.id not in self._fits:
                area = shown_area(wall).buffer(
                    -MARGIN * min(wall.width, wall.height), join_style="mitre"
                )
                self._fits[wall.id] = _fit(self._footprint(), area, wall.stage.center)
            return self._fits[wall.id]

    def _footprint(self) -> Polygon | MultiPolygon:
        """The land the data covers, holes between tracts filled, simplified for the fit
        and grown by what simplifying took, so every tract lies inside it."""
        if not len(self.shapes):
            return shapely.box(*self.extent)
        tolerance = self.size * FIT_OF_EXTENT
        land = shapely.union_all(self.outlines(tolerance))  # within tolerance of the tracts
        filled = shapely.union_all([Polygon(part.exterior) for part in _polygons(land)])
        footprint: Polygon | MultiPolygon = filled.simplify(tolerance).buffer(
            2 * tolerance, join_style="mitre"
        )
        return footprint


def visual_centre(shape: Polygon | MultiPolygon) -> tuple[tuple[float, float], float]:
    """Where a code or label reads best on a tract and how much fits there: the pole of
    inaccessibility of its largest part (polylabel) and the radius of the widest circle
    inside it around that point. Scale-free (its tolerance is a share of the part's
    size), so the plane's and the wall's outlines agree where the wall is the plane
    scaled."""
    largest = _largest(shape)
    tolerance = max(math.sqrt(largest.area) / 100, 1e-9)
    point = polylabel(largest, tolerance)
    room = largest.exterior.distance(point) if largest.area else 0.0
    for hole in largest.interiors:
        room = min(room, hole.distance(point))
    return (point.x, point.y), room


def shown_area(wall: Wall) -> Polygon | MultiPolygon:
    """The scene area of the displays that show the map, with the bezels between two of
    them (closing the displays' union over the widest bezel: a gap that two shown
    displays face across), not those beside a designated screen or the wall's edge.
    Every display when all are designated, as the stage then takes them all."""
    rects = _free_rects(wall) or [v.scene_rect for v in wall.viewports().values()]
    shown = shapely.union_all([shapely.box(r.x, r.y, r.right, r.bottom) for r in rects])
    bezel = max(
        (
            gap
            for a, b in itertools.permutations(rects, 2)
            for gap, along, size in (
                (b.x - a.right, a.overlap(b)[1], a.width),
                (b.y - a.bottom, a.overlap(b)[0], a.height),
            )
            if along > 0 and 0 < gap < BEZEL_OF_DISPLAY * size
        ),
        default=0.0,
    )
    if not bezel:
        return shown
    closed: Polygon | MultiPolygon = shown.buffer(bezel / 2, join_style="mitre").buffer(
        -bezel / 2, join_style="mitre"
    )
    return closed


def _fit(
    footprint: Polygon | MultiPolygon, area: Polygon | MultiPolygon, start: tuple[float, float]
) -> Projection:
    """The largest scale, and a placement, at which ``footprint`` (plane) lies within
    ``area`` (scene mm), searched numerically: the footprint's middle is tried on a grid
    over the area, nearest ``start`` first (so ties go to it), each try grown by
    bisection only where it beats the best so far; the best is then moved by a pattern
    search with halving steps, and at last centred in the room left at its scale, along
    x then y. Fixed orders, no randomness: the same inputs give the same fit."""
    shapely.prepare(area)
    minx, miny, maxx, maxy = footprint.bounds
    middle = np.array(((minx + maxx) / 2, (miny + maxy) / 2))
    half = np.array((max(maxx - minx, 1e-12) / 2, max(maxy - miny, 1e-12) / 2))
    low_corner, high_corner = np.array(area.bounds[:2]), np.array(area.bounds[2:])
    shorter = float(min(high_corner - low_corner))
    step, finest = shorter / FIT_GRID, shorter * FIT_PRECISION

    def fits(scale: float, at: Floats) -> bool:
        moved = shapely.transform(footprint, lambda p: (p - middle) * scale + at)
        return bool(area.covers(moved))

    def grown(at: Floats, beat: float) -> float:
        """The largest scale above ``beat`` that fits at ``at`` (``beat`` when none)."""
        high = float(min(np.minimum(at - low_corner, high_corner - at) / half))
        low = beat * (1 + FIT_PRECISION) if beat else high * FIT_PRECISION
        if low >= high or not fits(low, at):
            return beat
        while high > low * (1 + FIT_PRECISION):
            mid = (low + high) / 2
            low, high = (mid, high) if fits(mid, at) else (low, mid)
        return low

    tries = [
        np.array(p)
        for p in itertools.product(
            np.arange(low_corner[0] + step / 2, high_corner[0], step),
            np.arange(low_corner[1] + step / 2, high_corner[1], step),
        )
    ]
    tries.sort(key=lambda p: (math.dist(p, start), p[1], p[0]))
    scale, at = 0.0, np.array(start)
    for place in tries:
        if (better := grown(place, scale)) > scale:
            scale, at = better, place
    if not scale:
        raise ValueError("no room for the map on the displays that show it")
    directions = [np.array(d) for d in itertools.product((-1, 0, 1), repeat=2) if any(d)]
    step /= 2
    while step > finest:
        for direction in directions:
            place = at + direction * step
            if (better := grown(place, scale)) > scale:
                scale, at = better, place
                break
        else:
            step /= 2
    for axis in (0, 1):
        along = np.eye(2)[axis]
        ends = []
        for sign in (-1, 1):
            inside, outside = 0.0, float(high_corner[axis] - low_corner[axis])
            while outside - inside > finest:
                mid = (inside + outside) / 2
                if fits(scale, at + sign * mid * along):
                    inside = mid
                else:
                    outside = mid
            ends.append(inside)
        centred = at + (ends[1] - ends[0]) / 2 * along
        if fits(scale, centred):
            at = centred
    return Projection(scale, float(at[0] - scale * middle[0]), float(at[1] - scale * middle[1]))


def _simplify(shapes: Shapes, tolerance: float) -> Shapes:
    """Each outline within ``tolerance`` of the true one (Douglas-Peucker bounds the
    distance; neighbours' shared edges may part by twice that, under a pixel, which
    the outline stroke covers)."""
    simplified: Shapes = shapely.simplify(shapes, tolerance, preserve_topology=True)
    return simplified


@dataclass(frozen=True)
class Projection:
    """Plane -> scene mm for one view: ``x = scale · u + dx``, ``y = scale · v + dy``."""

    scale: float
    dx: float
    dy: float

    @property
    def affine(self) -> Affine:
        return (self.scale, 0.0, 0.0, self.scale, self.dx, self.dy)

    def point(self, u: float, v: float) -> tuple[float, float]:
        return (self.scale * u + self.dx, self.scale * v + self.dy)

    def to_plane(self, x: float, y: float) -> tuple[float, float]:
        return ((x - self.dx) / self.scale, (y - self.dy) / self.scale)

    def points(self, uv: Floats) -> Floats:
        """Plane points (n, 2) on the wall (scene mm): every one is placed."""
        return np.asarray(uv, dtype=np.float64).reshape(-1, 2) * self.scale + (self.dx, self.dy)

    def outlines(self, shapes: Shapes) -> Shapes:
        """Tracts' outlines on the wall (scene mm)."""
        moved: Shapes = shapely.transform(shapes, self.points)
        return moved

    def outline(self, shape: Polygon | MultiPolygon) -> Polygon | MultiPolygon:
        """One tract's outline on the wall (scene mm)."""
        moved: Polygon | MultiPolygon = self.outlines(np.array([shape], dtype=object))[0]
        return moved

    def anchors(
        self, geometry: MapGeometry, which: Sequence[int] | None = None
    ) -> tuple[Floats, Floats]:
        """The tracts' label points on the wall and the room around each (scene mm):
        the plane's, scaled (the plane's visual centres are the wall's)."""
        chosen = slice(None) if which is None else list(which)
        return self.points(geometry.label_points[chosen]), geometry.room[chosen] * self.scale


class MapProjection(Protocol):
    """Where the map's plane appears on the wall (scene mm) at one view: the flat map
    (:class:`Projection`) or the globe seen through the wall (``globe.GlobeProjection``).
    Codes, their room on a tract, and balloons are placed through it."""

    @property
    def scale(self) -> float:
        """Scene mm per plane unit at the middle of the wall (sizes clusters' cells)."""
        ...

    def points(self, uv: Floats) -> Floats:
        """Plane points (n, 2) on the wall, NaN where the wall does not show them."""
        ...

    def outlines(self, shapes: Shapes) -> Shapes:
        """Tracts' outlines on the wall, each empty where the wall does not show it."""
        ...

    def anchors(
        self, geometry: MapGeometry, which: Sequence[int] | None = None
    ) -> tuple[Floats, Floats]:
        """Where each tract (``which``: these, by index) wants its code on the wall and
        the radius of the widest circle inside the tract around it there (scene mm;
        NaN and 0 where the wall does not show the tract)."""
        ...


def projection(geometry: MapGeometry, wall: Wall, view: View) -> Projection:
    """At zoom 1 and centre (0.5, 0.5) the data as :meth:`MapGeometry.fit` puts it. The
    view then pans it as every scene layer (its centre moves by fractions of the stage)
    and zooms it about where the data's middle stands at zoom 1, as every layer does
    about its picture's middle: the fit may put the map off the stage's centre, and
    zooming in keeps it on the wall."""
    fitted = geometry.fit(wall)
    minx, miny, maxx, maxy = geometry.extent
    middle_x, middle_y = fitted.point((minx + maxx) / 2, (miny + maxy) / 2)
    stage = wall.stage
    pan_x, pan_y = (view.center[0] - 0.5) * stage.width, (view.center[1] - 0.5) * stage.height
    zoom = view.zoom
    return Projection(
        scale=zoom * fitted.scale,
        dx=middle_x + zoom * (fitted.dx - middle_x - pan_x),
        dy=middle_y + zoom * (fitted.dy - middle_y - pan_y),
    )


def looking_at(
    geometry: MapGeometry, wall: Wall, view: View, middle: tuple[float, float], u: float, v: float
) -> View:
    """``view`` moved (its zoom kept) so that the scene point ``middle`` (the middle of
    the wall) shows the plane point (``u``, ``v``): :func:`projection` undone for the
    centre. The flat map and the globe both look there (the globe's camera stands over
    the point the middle of the wall shows)."""
    fitted = geometry.fit(wall)
    minx, miny, maxx, maxy = geometry.extent
    middle_x, middle_y = fitted.point((minx + maxx) / 2, (miny + maxy) / 2)
    zoom = view.zoom
    pan_x = u * fitted.scale + fitted.dx - middle_x - (middle[0] - middle_x) / zoom
    pan_y = v * fitted.scale + fitted.dy - middle_y - (middle[1] - middle_y) / zoom
    stage = wall.stage
    center = (0.5 + pan_x / stage.width, 0.5 + pan_y / stage.height)
    return view.model_copy(update={"center": center})


def tract_boxes(
    geometry: MapGeometry, wall: Wall, view: View, *, mapping: MapProjection | None = None
) -> list[Rect]:
    """The bounding box in scene mm of each tract the wall shows at ``view``, of its
    outline as ``mapping`` puts it (default: the flat map): where the map lies."""
    project = mapping or projection(geometry, wall, view)
    bounds = shapely.bounds(project.outlines(geometry.shapes))
    return [
        Rect(minx, miny, maxx - minx, maxy - miny)
        for minx, miny, maxx, maxy in bounds
        if not math.isnan(minx)
    ]


def label_mm(wall: Wall) -> float:
    """Tract numbers as tall as reads from where people scan."""
    return LABEL_MM_PER_M * wall.seat_distance_m


def code_anchors(
    geometry: MapGeometry,
    wall: Wall,
    view: View,
    code_side_mm: float,
    spacing_mm: tuple[float, float] | None = None,
    *,
    mapping: MapProjection | None = None,
) -> dict[str, tuple[float, float]]:
    """Where the tracts that can carry their own code want it (scene mm), by GEOID.

    A tract carries one when a circle as wide as the code fits inside it around its
    label point, that point is on a display showing the map (not a designated
    screen), and the code would not come within ``spacing_mm`` (across, down; default
    the code's side: a code with its caption and the gap kept around it) of a bigger
    tract's code there; the others are too small at this view (see
    :func:`tract_codes`). Tracts stand where ``mapping`` puts them (default: the flat
    map), their room measured there: on a tilted globe a tract far up the wall is
    foreshortened and may have none.
    """
    project = mapping or projection(geometry, wall, view)
    points, room = project.anchors(geometry)
    return _own_codes(geometry, wall, points, room, code_side_mm, spacing_mm)


def _own_codes(
    geometry: MapGeometry,
    wall: Wall,
    points: Floats,
    room: Floats,
    code_side_mm: float,
    spacing_mm: tuple[float, float] | None,
) -> dict[str, tuple[float, float]]:
    """:func:`code_anchors` from the tracts' anchors and room on the wall."""
    apart_x, apart_y = spacing_mm or (code_side_mm, code_side_mm)
    free = _free_rects(wall)
    fits = np.flatnonzero(room >= code_side_mm / 2)
    anchors: dict[str, tuple[float, float]] = {}
    for index in fits[np.argsort(-room[fits], kind="stable")]:
        x, y = (float(c) for c in points[index])
        if not shows_map(free, (x, y)):
            continue
        if any(abs(x - ax) < apart_x and abs(y - ay) < apart_y for ax, ay in anchors.values()):
            continue
        anchors[geometry.geoids[index]] = (x, y)
    return anchors


def pointer_targets(
    geometry: MapGeometry,
    wall: Wall,
    view: View,
    geoid: str,
    blocked: Sequence[Rect],
    margin_mm: float,
    *,
    mapping: MapProjection | None = None,
) -> list[tuple[float, float]]:
    """Where a balloon may point to show a tract (scene mm), best first: in each part
    of the tract that lies on a display showing the map (``margin_mm`` inside its
    edges) and outside ``blocked`` (codes with their captions, grown by what a pointer's
    dot needs), the point nearest the tract's label point, nearest first (at most
    :data:`POINTER_TARGETS`). A tract
    carrying its own code has it standing on its label point, so the first meets the
    tract at the code's edge, the others on its far sides. A tract wholly under codes
    or off the map's displays gets the nearest free point beside it (its label point
    when nothing is free). The tract stands where ``mapping`` puts it (default: the
    flat map); none when it puts the tract nowhere on the wall (over a globe's horizon
    or beyond the wall's edge)."""
    project = mapping or projection(geometry, wall, view)
    index = geometry.geoids.index(geoid)
    anchor, _ = project.anchors(geometry, [index])
    if np.isnan(anchor).any():
        return []
    label = shapely.Point(anchor[0])
    shown = shapely.union_all(
        [
            shapely.box(r.x, r.y, r.right, r.bottom).buffer(-margin_mm, join_style="mitre")
            for r in _free_rects(wall)
        ]
    )
    covered = shapely.union_all([shapely.box(r.x, r.y, r.right, r.bottom) for r in blocked])
    free = shapely.difference(shown, covered)
    tract = project.outlines(geometry.shapes[[index]])[0]
    for region in (shapely.intersection(tract, free), free):
        parts = [part for part in _polygons(region) if part.area > 0]
        if parts:
            points = [nearest_points(part, label)[0] for part in parts]
            points.sort(key=label.distance)
            return [(float(p.x), float(p.y)) for p in points[:POINTER_TARGETS]]
    return [(float(label.x), float(label.y))]


def _free_rects(wall: Wall) -> list[Rect]:
    """The scene rectangles of the displays that show the map (not designated ones)."""
    return [wall.viewport(d.id).scene_rect for d in wall.displays if d.id not in wall.designated()]


def shows_map(rects: Sequence[Rect], point: tuple[float, float]) -> bool:
    """Whether ``point`` (scene mm) lies on one of ``rects`` (:func:`_free_rects`)."""
    x, y = point
    return any(r.x <= x < r.right and r.y <= y < r.bottom for r in rects)


def on_the_map(wall: Wall) -> Callable[[tuple[float, float]], bool]:
    """Whether a point (scene mm) lies on a display showing the map: a code's anchor on
    a designated screen may lie under the panel's codes, where no pin head may go."""
    rects = _free_rects(wall)
    return lambda point: shows_map(rects, point)


@dataclass(frozen=True)
class Cluster:
    """Neighbouring tracts too small for their own code, reached through one code."""

    geoids: tuple[str, ...]
    anchor: tuple[float, float]  # scene mm: the middle of their label points


@dataclass(frozen=True)
class TractCodes:
    """Every tract a person can reach by pointing at the wall at one view."""

    own: dict[str, tuple[float, float]]  # GEOID -> where its own code wants to stand
    clusters: tuple[Cluster, ...]

    def anchors(self) -> list[tuple[str, tuple[float, float]]]:
        """Every code's key and anchor, in the order they are placed: own codes first
        (``tract:GEOID``), then clusters (``cluster:N``)."""
        return [(f"tract:{g}", a) for g, a in self.own.items()] + [
            (f"cluster:{n}", c.anchor) for n, c in enumerate(self.clusters)
        ]

    def keeping(self, placed: set[str]) -> TractCodes:
        """These codes with only the ``placed`` keys: the tracts of a code that found no
        spot join the nearest cluster that did (its code stays where it is), so they
        stay reachable from the wall."""
        own = {g: a for g, a in self.own.items() if f"tract:{g}" in placed}
        kept = [c for n, c in enumerate(self.clusters) if f"cluster:{n}" in placed]
        if not kept:
            return TractCodes(own, ())
        joining: list[list[str]] = [[] for _ in kept]
        homeless = [(g, a) for g, a in self.own.items() if g not in own]
        homeless += [
            (g, c.anchor)
            for n, c in enumerate(self.clusters)
            if f"cluster:{n}" not in placed
            for g in c.geoids
        ]
        for geoid, (x, y) in homeless:
            nearest = min(
                range(len(kept)),
                key=lambda i: math.hypot(kept[i].anchor[0] - x, kept[i].anchor[1] - y),
            )
            joining[nearest].append(geoid)
        clusters = tuple(
            Cluster(tuple(sorted((*c.geoids, *extra))), c.anchor)
            for c, extra in zip(kept, joining, strict=True)
        )
        return TractCodes(own, clusters)

    def settled(
        self, places: Callable[[list[tuple[str, tuple[float, float]]]], set[str]]
    ) -> TractCodes:
        """These codes once every one finds a spot: those that ``places`` (the keys of
        the anchors given that find a spot) leaves out are handed to clusters that do
        (:meth:`keeping`), and the rest tried again, until none is left out. One try is
        not enough: with an anchor gone, the codes placed before it may stand over it
        (no code hides another's pin head), and a later one can lose its spot."""
        codes = self
        while True:
            anchors = codes.anchors()
            placed = places(anchors)
            if len(placed) == len(anchors):
                return codes
            codes = codes.keeping(placed)


def tract_codes(
    geometry: MapGeometry,
    wall: Wall,
    view: View,
    code_side_mm: float,
    footprint_mm: tuple[float, float],
    *,
    mapping: MapProjection | None = None,
) -> TractCodes:
    """Own codes for the tracts with room for one (:func:`code_anchors`), and cluster
    codes for the rest, as marker clustering on web maps does.

    The tracts too small for a code whose label point is on (or beside, behind a
    bezel) a display showing the map are grouped by cells of :data:`CLUSTER_CELL`
    footprints (``footprint_mm``: a code with its caption and gap) on the data's plane,
    so clusters do not change when the map pans; a cluster's code wants to stand at
    the middle of its tracts' label points (placement moves it aside, on a pin, where
    another code stands). Crowded cells are split (:func:`_median_cut`). A cluster of
    one tract is that tract's own code, standing on its label point.

    Tracts stand where ``mapping`` puts them on the wall (default: the flat map; on the
    globe, where its camera shows them, :func:`code_anchors`); the cells stay the
    plane's, sized at the middle of the wall's scale.
    """
    project = mapping or projection(geometry, wall, view)
    anchors, room = project.anchors(geometry)
    own = _own_codes(geometry, wall, anchors, room, code_side_mm, footprint_mm)
    width, height = (CLUSTER_CELL * side for side in footprint_mm)
    near = [grown(r, min(footprint_mm) / 2) for r in _free_rects(wall)]
    cells: dict[tuple[int, int], list[int]] = {}
    points = geometry.label_points
    minx, miny, _, _ = geometry.extent
    for index, (u, v) in enumerate(geometry.label_points):
        if geometry.geoids[index] in own:
            continue
        x, y = (float(c) for c in anchors[index])
        if not shows_map(near, (x, y)):  # NaN (not on the wall) lies on none
            continue
        cell = (
            math.floor((u - minx) * project.scale / width),
            math.floor((v - miny) * project.scale / height),
        )
        cells.setdefault(cell, []).append(index)
    clusters = []
    parts = [part for key in sorted(cells) for part in _median_cut(cells[key], points)]
    for members in parts:
        x, y = np.mean(anchors[members], axis=0)
        geoids = tuple(sorted(geometry.geoids[i] for i in members))
        if len(geoids) == 1:
            own[geoids[0]] = (float(x), float(y))
        else:
            clusters.append(Cluster(geoids, (float(x), float(y))))
    return TractCodes(own, tuple(clusters))


def _median_cut(members: list[int], points: Floats) -> list[list[int]]:
    """``members`` split at the median along their longer side, again and again, until
    no part holds more than :data:`MAX_CLUSTER_TRACTS` (a list a phone shows at once):
    a dense downtown gets several codes side by side rather than one long list."""
    if len(members) <= MAX_CLUSTER_TRACTS:
        return [members]
    coords = points[members]
    axis = int(np.argmax(coords.max(axis=0) - coords.min(axis=0)))
    order = [members[i] for i in np.argsort(coords[:, axis], kind="stable")]
    half = len(order) // 2
    return _median_cut(order[:half], points) + _median_cut(order[half:], points)


def grown(rect: Rect, margin: float) -> Rect:
    """``rect`` with ``margin`` added on every side."""
    return Rect(rect.x - margin, rect.y - margin, rect.width + 2 * margin, rect.height + 2 * margin)


def tile_view(
    dataset: DataSet,
    geometry: MapGeometry,
    wall: Wall,
    display_id: str,
    view: View,
    codes: dict[str, str],
    occupied: Sequence[Rect] = (),
) -> dict[str, Any]:
    """One tile's share of the map, in that display's native pixels: the tracts it
    shows (outlines clipped to it, simplified under half a pixel), their labels,
    groups and codes (``codes``: GEOID -> code of the tracts that carry one), and how
    to draw them (:data:`COLOURS`; outlines as wide as read from the seats).

    A tract's label is offered (``label_at``) only where it stays clear of
    ``occupied`` (scene mm: the codes on this display with their captions), so a map
    label never runs into a code or its caption."""
    viewport = wall.viewport(display_id)
    project = projection(geometry, wall, view)
    to_pixels = viewport.to_pixels
    px_per_mm = min(math.hypot(to_pixels[0], to_pixels[1]), math.hypot(to_pixels[2], to_pixels[3]))
    label_px = label_mm(wall) * px_per_mm
    outline_px = max(MIN_OUTLINE_PX, OUTLINE_MM_PER_M * wall.seat_distance_m * px_per_mm)
    rect = viewport.scene_rect
    reach = 8 * label_mm(wall)  # labels of tracts just off the tile still reach into it
    u0, v0 = project.to_plane(rect.x - reach, rect.y - reach)
    u1, v1 = project.to_plane(rect.right + reach, rect.bottom + reach)
    b = geometry.bounds
    near = np.flatnonzero((b[:, 0] <= u1) & (b[:, 2] >= u0) & (b[:, 1] <= v1) & (b[:, 3] >= v0))
    outlines = geometry.outlines(SIMPLIFY_PX / px_per_mm / project.scale)[near]
    clipped = shapely.clip_by_rect(outlines, u0, v0, u1, v1)
    plane_to_pixels = compose_affine(to_pixels, project.affine)
    a, bb, c, d, e, f = plane_to_pixels
    matrix = np.array([[a, c], [bb, d]])
    offset = np.array([e, f])
    tracts = []
    for index, shape in zip(near, clipped, strict=True):
        if shape.is_empty:
            continue
        tract = dataset.tracts[index]
        rings = [
            _pixel_ring(np.asarray(ring.coords) @ matrix.T + offset)
            for polygon in _polygons(shape)
            for ring in (polygon.exterior, *polygon.interiors)
        ]
        x, y = apply_affine(plane_to_pixels, *geometry.label_points[index])
        sx, sy = project.point(*geometry.label_points[index])
        half_w = len(tract.label) * LABEL_WIDTH_OF_HEIGHT * label_mm(wall) / 2
        half_h = label_mm(wall) / 2
        label_box = Rect(sx - half_w, sy - half_h, 2 * half_w, 2 * half_h)
        tracts.append(
            {
                "id": tract.geoid,
                "label": tract.label,
                "group": dataset.group_of[tract.geoid],
                "code": codes.get(tract.geoid),
                "at": [round(x, 1), round(y, 1)],
                "room": round(float(geometry.room[index]) * project.scale * px_per_mm, 1),
                "label_clear": not any(label_box.intersects(area) for area in occupied),
                "rings": [ring for ring in rings if len(ring) >= 6],
            }
        )
    return {
        "dataset": dataset.id,
        "title": dataset.title,
        "label_px": round(label_px, 1),
        "outline_px": round(outline_px, 1),
        "colours": COLOURS,
        "tracts": tracts,
    }


def _polygons(shape: Any) -> list[Polygon]:
    if isinstance(shape, Polygon):
        return [shape]
    return [g for g in getattr(shape, "geoms", ()) if isinstance(g, Polygon)]


def _pixel_ring(points: Floats) -> list[int]:
    """A ring as flat whole-pixel coordinates, without repeated points."""
    whole = np.rint(points).astype(np.int64)
    keep = np.ones(len(whole), dtype=bool)
    keep[1:] = np.any(whole[1:] != whole[:-1], axis=1)
    flat: list[int] = whole[keep].ravel().tolist()
    return flat
