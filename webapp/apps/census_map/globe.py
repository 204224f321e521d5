"""The census map on a globe: what every tile of a wall needs to draw its part of one
wall camera (CesiumJS on the tiles, ``static/globe.js``).

The wall is a window onto the Earth: the eye stands ``seat_distance_m`` in front of the
middle of the wall, the camera as high above the ground, scaled to the map, looking
straight down at the point of the map the middle of the wall shows. Each display then
sees through its own rectangle of that window (``static/frustum.js`` turns the rectangle
into an off-centre frustum), so the globe runs on straight across the bezels. At the
middle the globe shows the map at the flat map's scale and place, so codes anchored on
tracts stand on them on the globe too (within a percent of the distance from the middle:
the globe is a perspective of the curved WGS84 ellipsoid, the flat map a plane).
"""

from __future__ import annotations

import math
from typing import Any

from shapely.geometry import MultiPolygon, Polygon

from wall_client.layout import Wall
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.earth import WGS84_A, WGS84_E2
from webapp.apps.census_map.mapview import SIMPLIFY_PX, MapGeometry, projection
from webapp.engine.wall_state import View

DEGREES_DIGITS = 6  # a tenth of a metre: far under a pixel at any wall's scale


def wall_middle(wall: Wall) -> tuple[float, float]:
    """The middle of the scene all displays show (scene mm): where the eye looks."""
    rects = [wall.viewport(d.id).scene_rect for d in wall.displays]
    x0, y0 = min(r.x for r in rects), min(r.y for r in rects)
    x1, y1 = max(r.right for r in rects), max(r.bottom for r in rects)
    return ((x0 + x1) / 2, (y0 + y1) / 2)


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
