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


def globe_camera(geometry: MapGeometry, wall: Wall, view: View) -> dict[str, Any]:
    """The wall's one camera: the eye (scene mm of the middle and its distance), and
    where it stands over the Earth (longitude, latitude, height in metres)."""
    project = projection(geometry, wall, view)
    eye = wall_eye(wall)
    longitude, latitude = geometry.to_lonlat(*project.to_plane(eye["x"], eye["y"]))
    metres_per_mm = ground_m_per_unit(geometry.lat0) / project.scale
    return {
        "eye": eye,
        "longitude": longitude,
        "latitude": latitude,
        "height_m": eye["distance_mm"] * metres_per_mm,
    }


def globe_view(dataset: DataSet, geometry: MapGeometry, wall: Wall, view: View) -> dict[str, Any]:
    """The camera and every tract in longitude/latitude, simplified to within a quarter
    pixel of the wall's finest display at ``view``, with their groups: the same for every
    tile of the wall."""
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
    return {"dataset": dataset.id, "camera": globe_camera(geometry, wall, view), "tracts": tracts}


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
