"""The census map on the wall: where tracts fall for a view, which can carry a code,
and one tile's share of the map.

Tracts are put once on a flat plane (x = longitude · cos φ0, y = -latitude, φ0 the
data set's middle latitude: an equirectangular projection, true to shape at the
scale of a county). The plane differs from the wall's scene only by a scale and a
shift, so a pan or zoom never redoes geometry: it changes :class:`Projection`.
Outlines are simplified at a few tolerances, each twice the one before, and each
tile takes the coarsest that stays within half a pixel of the true outline.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
from shapely import MultiPolygon, Polygon
from shapely.ops import polylabel

from wall_client.layout import ROLES, Affine, Wall, apply_affine, compose_affine
from webapp.apps.census_map.dataset import DataSet
from webapp.wall_state import View

MARGIN = 0.03  # of the wall left around the data at zoom 1
LEVELS = 8  # simplified outlines kept, each twice as coarse as the one before
FINEST_OF_EXTENT = 2.0**-16  # the finest level's tolerance, as a share of the data's size
LABEL_MM_PER_M = 6.0  # tract-number height (mm) per metre of scanning distance
SIMPLIFY_PX = 0.25  # simplification tolerance: outlines stay well within half a pixel
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
    _levels: dict[int, Shapes] = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @classmethod
    def of(cls, dataset: DataSet) -> MapGeometry:
        shapes_ll = np.array([t.shape for t in dataset.tracts], dtype=object)
        lat0 = float(np.mean(shapely.bounds(shapes_ll)[:, [1, 3]])) if len(shapes_ll) else 0.0
        shapes = shapely.transform(shapes_ll, _plane(lat0))
        bounds = shapely.bounds(shapes)
        points, room = [], []
        for shape in shapes:
            largest = _largest(shape)
            # polylabel: the pole of inaccessibility, the visual centre a code and a
            # label read best at; its distance to the outline says how much fits.
            tolerance = max(math.sqrt(largest.area) / 100, 1e-9)
            point = polylabel(largest, tolerance)
            points.append((point.x, point.y))
            room.append(largest.exterior.distance(point) if largest.area else 0.0)
            for hole in largest.interiors:
                room[-1] = min(room[-1], hole.distance(point))
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
        )

    @property
    def size(self) -> float:
        minx, miny, maxx, maxy = self.extent
        return max(maxx - minx, maxy - miny, 1e-12)

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


def projection(geometry: MapGeometry, wall: Wall, view: View) -> Projection:
    """At zoom 1 the data fills the wall (with a margin), centred; the view then pans
    and zooms about the wall's centre exactly as every scene layer does."""
    minx, miny, maxx, maxy = geometry.extent
    usable_w, usable_h = wall.width * (1 - 2 * MARGIN), wall.height * (1 - 2 * MARGIN)
    base = min(usable_w / max(maxx - minx, 1e-12), usable_h / max(maxy - miny, 1e-12))
    cx, cy = view.center
    zoom = view.zoom
    mid_u, mid_v = (minx + maxx) / 2, (miny + maxy) / 2
    return Projection(
        scale=zoom * base,
        dx=wall.width / 2 + zoom * (wall.width / 2 - base * mid_u - cx * wall.width),
        dy=wall.height / 2 + zoom * (wall.height / 2 - base * mid_v - cy * wall.height),
    )


def label_mm(wall: Wall) -> float:
    """Tract numbers as tall as reads from where people scan."""
    return LABEL_MM_PER_M * wall.scan_distance_m


def code_anchors(
    geometry: MapGeometry, wall: Wall, view: View, code_side_mm: float
) -> dict[str, tuple[float, float]]:
    """Where the tracts that can carry a code want it (scene mm), by GEOID.

    A tract carries one when a circle as wide as the code fits inside it around its
    label point, that point is on a display showing the map (not a designated
    screen), and the code would not overlap a bigger tract's code there; the others
    are too small at this view and stay reachable from the tract index.
    """
    project = projection(geometry, wall, view)
    designated = {d.id for role in ROLES for d in wall.screen(role)}
    shows_map = [wall.viewport(d.id).scene_rect for d in wall.displays if d.id not in designated]
    fits = np.flatnonzero(geometry.room * project.scale >= code_side_mm / 2)
    anchors: dict[str, tuple[float, float]] = {}
    for index in fits[np.argsort(-geometry.room[fits], kind="stable")]:
        x, y = project.point(*geometry.label_points[index])
        if not any(r.x <= x < r.right and r.y <= y < r.bottom for r in shows_map):
            continue
        if any(
            abs(x - ax) < code_side_mm and abs(y - ay) < code_side_mm for ax, ay in anchors.values()
        ):
            continue
        anchors[geometry.geoids[index]] = (x, y)
    return anchors


def tile_view(
    dataset: DataSet,
    geometry: MapGeometry,
    wall: Wall,
    display_id: str,
    view: View,
    codes: dict[str, str],
) -> dict[str, Any]:
    """One tile's share of the map, in that display's native pixels: the tracts it
    shows (outlines clipped to it, simplified under half a pixel), their labels,
    groups and codes (``codes``: GEOID -> code of the tracts that carry one)."""
    viewport = wall.viewport(display_id)
    project = projection(geometry, wall, view)
    to_pixels = viewport.to_pixels
    px_per_mm = min(math.hypot(to_pixels[0], to_pixels[1]), math.hypot(to_pixels[2], to_pixels[3]))
    label_px = label_mm(wall) * px_per_mm
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
        tracts.append(
            {
                "id": tract.geoid,
                "label": tract.label,
                "group": dataset.group_of[tract.geoid],
                "code": codes.get(tract.geoid),
                "at": [round(x, 1), round(y, 1)],
                "room": round(float(geometry.room[index]) * project.scale * px_per_mm, 1),
                "rings": [ring for ring in rings if len(ring) >= 6],
            }
        )
    return {
        "dataset": dataset.id,
        "title": dataset.title,
        "label_px": round(label_px, 1),
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
