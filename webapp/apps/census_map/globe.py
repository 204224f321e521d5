"""The census map on a globe: what every tile of a wall needs to draw its part of one
wall camera (CesiumJS on the tiles, ``static/globe.js``).

The wall is a window onto the Earth: the eye stands ``seat_distance_m`` in front of the
middle of the wall, the camera as high above the ground, scaled to the map, looking
straight down at the point of the map the middle of the wall shows. Each display then
sees through its own rectangle of that window (``static/frustum.js`` turns the rectangle
into an off-centre frustum), so the globe runs on straight across the bezels. At the
middle the globe shows the map at the flat map's scale and place; away from it, straight
down, places stand up to 2.4 % of their distance from the middle off the flat map's
(demo wall; 2.9 % on HIPerWall): the globe is a perspective of the curved WGS84
ellipsoid, the flat map an equirectangular plane.

:class:`GlobeProjection` is that camera undone for the codes: where a place of the map
appears on the wall (scene mm), so codes, their room on a tract and balloons stand on
the tract's pixels, straight down or turned and tilted.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon

from wall_client.layout import Rect, Wall
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.ellipsoid import WGS84_A, WGS84_E2
from webapp.apps.census_map.mapview import (
    SIMPLIFY_PX,
    Floats,
    MapGeometry,
    MapProjection,
    Shapes,
    projection,
    visual_centre,
)
from webapp.apps.census_map.state import Surface
from webapp.engine.wall_state import View

DEGREES_DIGITS = 6  # a tenth of a metre: far under a pixel at any wall's scale
ANCHOR_MM = 0.5  # tracts' outlines on the wall for codes' room: within this of the truth


def wall_window(wall: Wall) -> Rect:
    """The scene all displays show (scene mm): the window the eye looks through."""
    rects = [wall.viewport(d.id).scene_rect for d in wall.displays]
    x0, y0 = min(r.x for r in rects), min(r.y for r in rects)
    x1, y1 = max(r.right for r in rects), max(r.bottom for r in rects)
    return Rect(x0, y0, x1 - x0, y1 - y0)


def wall_middle(wall: Wall) -> tuple[float, float]:
    """The middle of the scene all displays show (scene mm): where the eye looks."""
    return wall_window(wall).center


def wall_eye(wall: Wall) -> dict[str, float]:
    """Where the wall's one eye stands: ``seat_distance_m`` in front of the middle of
    the scene (scene mm). Each display's frustum is its rectangle seen from here
    (``static/frustum.js``)."""
    x, y = wall_middle(wall)
    return {"x": x, "y": y, "distance_mm": wall.seat_distance_m * 1000}


def ground_m_per_unit(latitude: float) -> float:
    """Metres of ground east-west per unit of the map's plane (a degree of longitude
    times cos(lat0)) on the WGS84 ellipsoid: its prime vertical radius, per radian."""
    phi = math.radians(latitude)
    return WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(phi) ** 2) * math.pi / 180


def globe_camera(
    geometry: MapGeometry, wall: Wall, view: View, heading: float = 0.0, tilt: float = 0.0
) -> dict[str, Any]:
    """The wall's one camera: the eye (scene mm of the middle and its distance), the
    target (the point of the map the middle of the wall shows, on the ellipsoid), and
    the camera ``range_m`` from it, turned by ``heading`` (degrees clockwise from north:
    the way the top of the wall faces) and tilted ``tilt`` degrees from straight down
    towards it, as the eye would see the map hung that far off the wall. At heading 0,
    tilt 0 the camera stands straight above the target, north up.

    Where it stands: ``longitude``, ``latitude``, ``height_m`` and ``position`` (Earth-
    centred, metres); which way it looks: ``direction``, and ``up``, the way the top of
    the wall faces (unit vectors, Earth-centred). Each display turns these into its own
    off-centre part of the one camera (``static/frustum.js``, ``static/globe.js``), so a
    tilted view runs on across the bezels as a straight-down one does."""
    project = projection(geometry, wall, view)
    eye = wall_eye(wall)
    longitude, latitude = geometry.to_lonlat(*project.to_plane(eye["x"], eye["y"]))
    metres_per_mm = ground_m_per_unit(geometry.lat0) / project.scale
    range_m = eye["distance_mm"] * metres_per_mm
    east, north, up = _enu(longitude, latitude)
    h, t = math.radians(heading), math.radians(tilt)
    # in the target's east, north, up: the look down and towards the heading, and the
    # top of the wall's picture (perpendicular to it, towards the heading and up)
    look = (math.sin(h) * math.sin(t), math.cos(h) * math.sin(t), -math.cos(t))
    top = (math.sin(h) * math.cos(t), math.cos(h) * math.cos(t), math.sin(t))

    def world(v: tuple[float, float, float]) -> list[float]:
        return [v[0] * e + v[1] * n + v[2] * u for e, n, u in zip(east, north, up, strict=True)]

    target = _ecef(longitude, latitude)
    direction = world(look)
    position = [p - range_m * d for p, d in zip(target, direction, strict=True)]
    cam_longitude, cam_latitude, height_m = _geodetic(position)
    return {
        "eye": eye,
        "longitude": cam_longitude,
        "latitude": cam_latitude,
        "height_m": height_m,
        "target": {"longitude": longitude, "latitude": latitude},
        "range_m": range_m,
        "heading": heading,
        "tilt": tilt,
        "position": position,
        "direction": direction,
        "up": world(top),
    }


Vector = tuple[float, float, float]


def _enu(longitude: float, latitude: float) -> tuple[Vector, Vector, Vector]:
    """East, north and up (the ellipsoid's normal) at a place, Earth-centred."""
    lam, phi = math.radians(longitude), math.radians(latitude)
    east = (-math.sin(lam), math.cos(lam), 0.0)
    north = (-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi))
    up = (math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi))
    return east, north, up


def _ecef(longitude: float, latitude: float, height: float = 0.0) -> list[float]:
    """A place on (or ``height`` metres above) the WGS84 ellipsoid, Earth-centred."""
    lam, phi = math.radians(longitude), math.radians(latitude)
    n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(phi) ** 2)
    return [
        (n + height) * math.cos(phi) * math.cos(lam),
        (n + height) * math.cos(phi) * math.sin(lam),
        (n * (1 - WGS84_E2) + height) * math.sin(phi),
    ]


def _geodetic(position: list[float]) -> tuple[float, float, float]:
    """Longitude, latitude (degrees) and height (metres) of an Earth-centred point
    (iterated to well under a millimetre at any height a wall's camera takes)."""
    x, y, z = position
    p = math.hypot(x, y)
    phi = math.atan2(z, p * (1 - WGS84_E2))
    height = 0.0
    for _ in range(10):
        n = WGS84_A / math.sqrt(1 - WGS84_E2 * math.sin(phi) ** 2)
        height = p / math.cos(phi) - n
        phi = math.atan2(z, p * (1 - WGS84_E2 * n / (n + height)))
    return math.degrees(math.atan2(y, x)), math.degrees(phi), height


@dataclass(frozen=True)
class GlobeProjection:
    """Where a place of the map appears on the wall (scene mm) under the globe's camera
    (:func:`globe_camera`): the plane point's longitude and latitude on the WGS84
    ellipsoid, seen from the camera through the wall's window, as each display draws
    its off-centre part of it (``static/frustum.js``, ``static/globe.js``). So a code
    placed there stands on its tract's pixels. Not placed (NaN) behind the camera,
    over the horizon, or beyond the wall's edge. Straight down, north up, it agrees
    with the flat map within 3 % of the distance from the middle of the wall
    (``tests/webapp/apps/census_map/test_globe.py`` measures it)."""

    position: tuple[float, float, float]  # the camera, Earth-centred (m)
    right: tuple[float, float, float]  # the wall's right, up and the camera's look:
    up: tuple[float, float, float]  # unit vectors, Earth-centred
    direction: tuple[float, float, float]
    eye: tuple[float, float, float]  # scene x, y of the eye and its distance (mm)
    window: Rect  # the wall's scene: points beyond it are not placed
    lat0: float  # the plane's middle latitude (MapGeometry.lat0)
    scale: float  # scene mm per plane unit at the middle of the wall (the flat map's)

    def seen(self, uv: Floats) -> Floats:
        """Plane points (n, 2) where the camera shows them in the wall's plane (scene
        mm), beyond the wall's edge too; NaN behind the camera or over the horizon."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        lam = np.radians(uv[:, 0] / math.cos(math.radians(self.lat0)))
        phi = np.radians(-uv[:, 1])
        n = WGS84_A / np.sqrt(1 - WGS84_E2 * np.sin(phi) ** 2)
        normal = np.column_stack(
            (np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi))
        )
        ground = normal * n[:, None]
        ground[:, 2] *= 1 - WGS84_E2
        towards = ground - np.array(self.position)
        depth = towards @ np.array(self.direction)
        # on a convex Earth a place is seen when the camera stands above its horizon
        # plane (the tangent plane there), and in front of the camera
        shown = (depth > 0) & (np.einsum("ij,ij->i", -towards, normal) > 0)
        depth = np.where(shown, depth, np.nan)
        x0, y0, distance = self.eye
        across = towards @ np.array(self.right) / depth
        upwards = towards @ np.array(self.up) / depth
        return np.column_stack((x0 + distance * across, y0 - distance * upwards))

    def points(self, uv: Floats) -> Floats:
        """Plane points (n, 2) on the wall (scene mm); NaN where not shown on it."""
        xy = self.seen(uv)
        w = self.window
        inside = (xy[:, 0] >= w.x) & (xy[:, 0] <= w.right)
        inside &= (xy[:, 1] >= w.y) & (xy[:, 1] <= w.bottom)
        xy[~inside] = np.nan
        return xy

    def point(self, u: float, v: float) -> tuple[float, float] | None:
        """One plane point on the wall (scene mm), None where not shown on it."""
        x, y = self.points(np.array([[u, v]]))[0]
        return None if math.isnan(x) else (float(x), float(y))

    def outlines(self, shapes: Shapes) -> Shapes:
        """Tracts' outlines on the wall (scene mm), cut at the wall's edge; empty where
        any of one is behind the camera or over the horizon (on a wall that sees the
        horizon, a tract that far is too small for a code). A perspective keeps an
        outline in front of the camera simple, so no repair is needed."""
        seen: Shapes = shapely.transform(shapes, self.seen)
        coords, owner = shapely.get_coordinates(seen, return_index=True)
        unseen = np.zeros(len(seen), dtype=bool)
        unseen[owner[np.isnan(coords).any(axis=1)]] = True
        w = self.window
        bounds = shapely.bounds(seen)
        beyond = ~unseen & (
            (bounds[:, 0] < w.x)
            | (bounds[:, 1] < w.y)
            | (bounds[:, 2] > w.right)
            | (bounds[:, 3] > w.bottom)
        )
        window = shapely.box(w.x, w.y, w.right, w.bottom)
        for index, cut in zip(
            np.flatnonzero(beyond), shapely.intersection(seen[beyond], window), strict=True
        ):
            seen[index] = _areas(cut)
        for index in np.flatnonzero(unseen):
            seen[index] = Polygon()
        return seen

    def outline(self, shape: Polygon | MultiPolygon) -> Polygon | MultiPolygon:
        """One tract's outline on the wall (:meth:`outlines`)."""
        found: Polygon | MultiPolygon = self.outlines(np.array([shape], dtype=object))[0]
        return found

    def anchors(
        self, geometry: MapGeometry, which: Sequence[int] | None = None
    ) -> tuple[Floats, Floats]:
        """Each tract's visual centre on the wall and the room around it (scene mm),
        from its outline as the camera shows it (:func:`mapview.visual_centre`): a tract
        foreshortened far up a tilted wall has less room than on the flat map."""
        chosen = slice(None) if which is None else list(which)
        outlines = self.outlines(geometry.outlines(ANCHOR_MM / self.scale)[chosen])
        points = np.full((len(outlines), 2), np.nan)
        room = np.zeros(len(outlines))
        for row, seen in enumerate(outlines):
            if not seen.is_empty:
                points[row], room[row] = visual_centre(seen)
        return points, room


def globe_projection(
    geometry: MapGeometry, wall: Wall, view: View, heading: float = 0.0, tilt: float = 0.0
) -> GlobeProjection:
    """The map on the wall as the globe's camera (turned and tilted so) shows it."""
    camera = globe_camera(geometry, wall, view, heading, tilt)
    eye = camera["eye"]
    direction, up = camera["direction"], camera["up"]
    right = np.cross(direction, up)  # as globe.js takes it: the camera's right
    return GlobeProjection(
        position=_vector(camera["position"]),
        right=_vector(right),
        up=_vector(up),
        direction=_vector(direction),
        eye=(eye["x"], eye["y"], eye["distance_mm"]),
        window=wall_window(wall),
        lat0=geometry.lat0,
        scale=projection(geometry, wall, view).scale,
    )


def map_projection(
    geometry: MapGeometry,
    wall: Wall,
    view: View,
    surface: Surface,
    heading: float = 0.0,
    tilt: float = 0.0,
) -> MapProjection:
    """Where the wall shows the map: on the globe as its camera sees it (turned,
    tilted or straight down), else flat. Codes, balloons and the legend are placed
    through it."""
    if surface == "globe":
        return globe_projection(geometry, wall, view, heading, tilt)
    return projection(geometry, wall, view)


def _vector(values: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return (x, y, z)


def globe_view(
    dataset: DataSet,
    geometry: MapGeometry,
    wall: Wall,
    view: View,
    heading: float = 0.0,
    tilt: float = 0.0,
) -> dict[str, Any]:
    """The camera (turned and tilted so) and every tract in longitude/latitude,
    simplified to within a quarter pixel of the wall's finest display at ``view``, with
    their groups: the same for every tile of the wall."""
    project = projection(geometry, wall, view)
    px_per_mm = max(
        max(math.hypot(m[0], m[1]), math.hypot(m[2], m[3]))
        for m in (wall.viewport(d.id).to_pixels for d in wall.displays)
    )
    outlines = geometry.outlines(SIMPLIFY_PX / px_per_mm / project.scale)
    cos0 = math.cos(math.radians(geometry.lat0))
    tracts = []
    for tract, shape in zip(dataset.tracts, outlines, strict=True):
        polygons = [
            [_degrees(ring.coords, cos0) for ring in (polygon.exterior, *polygon.interiors)]
            for polygon in _polygons(shape)
        ]
        if polygons:
            tracts.append(
                {"id": tract.geoid, "group": dataset.group_of[tract.geoid], "polygons": polygons}
            )
    camera = globe_camera(geometry, wall, view, heading, tilt)
    return {"dataset": dataset.id, "camera": camera, "tracts": tracts}


def _areas(shape: Any) -> Polygon | MultiPolygon:
    """The parts of ``shape`` with an area (a cut may leave lines and points)."""
    parts = [p for p in _polygons(shape) if p.area > 0]
    return MultiPolygon(parts) if len(parts) > 1 else (parts[0] if parts else Polygon())


def _polygons(shape: Any) -> list[Polygon]:
    if isinstance(shape, Polygon):
        return [shape] if not shape.is_empty else []
    if isinstance(shape, MultiPolygon):
        return [g for g in shape.geoms if not g.is_empty]
    return [g for g in getattr(shape, "geoms", ()) if isinstance(g, Polygon) and not g.is_empty]


def _degrees(coords: Any, cos0: float) -> list[float]:
    """A ring of the plane as flat longitude, latitude pairs."""
    return [
        value
        for u, v in coords
        for value in (round(u / cos0, DEGREES_DIGITS), round(-v, DEGREES_DIGITS))
    ]
