"""Each display's part of the wall's one camera, as ``static/frustum.js`` computes it
(run by Node, the one home of the rule), against the wall's geometry here: the displays'
frusta tile the wall's window exactly, the bezels' share between neighbours. And the
camera undone (``GlobeProjection``): where a place of the map appears on the wall, which
codes and balloons are placed by, lands on the pixel each display draws it at."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from itertools import permutations
from typing import Any

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from tests.conftest import wall_files
from tests.webapp.apps.census_map.conftest import sacramento
from wall_client.config import load_wall
from wall_client.layout import Rect, Wall, apply_affine, invert_affine
from webapp.apps.census_map.ellipsoid import WGS84_A, WGS84_E2
from webapp.apps.census_map.globe import (
    globe_camera,
    globe_projection,
    wall_eye,
    wall_middle,
    wall_window,
)
from webapp.apps.census_map.mapview import (
    MapGeometry,
    code_anchors,
    looking_at,
    projection,
    tract_boxes,
)
from webapp.core.settings import PROJECT_ROOT
from webapp.engine.wall_state import View

FRUSTUM_JS = PROJECT_ROOT / "webapp" / "apps" / "census_map" / "static" / "frustum.js"
MM = 1e-6  # how close, in scene mm at the wall


def frusta(wall: Wall, eye: dict[str, float]) -> dict[str, dict[str, Any]]:
    """``displayFrustum`` of every display of ``wall``, run by Node."""
    node = shutil.which("node")
    if node is None:
        pytest.fail("Node.js is not installed: run `make test` (it installs npm, and node)")
    displays = [
        {"id": d.id, "to_pixels": list(wall.viewport(d.id).to_pixels), "resolution": d.resolution}
        for d in wall.displays
    ]
    script = (
        f"import {{displayFrustum}} from {json.dumps(FRUSTUM_JS.as_uri())};\n"
        "let text = ''; for await (const chunk of process.stdin) text += chunk;\n"
        "const {displays, eye} = JSON.parse(text);\n"
        "console.log(JSON.stringify(Object.fromEntries("
        "displays.map((d) => [d.id, displayFrustum(d, eye)]))));\n"
    )
    answer = subprocess.run(
        [node, "--input-type=module", "-e", script],
        input=json.dumps({"displays": displays, "eye": eye}),
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    found: dict[str, dict[str, Any]] = json.loads(answer.stdout)
    return found


def window(wall: Wall, display_id: str, frustum: dict[str, Any], eye: dict[str, float]) -> Rect:
    """The rectangle of the wall (scene mm) a display's frustum looks through: its
    tangents along the picture's axes, which are the display's pixel axes in scene mm."""
    inverse = invert_affine(wall.viewport(display_id).to_pixels)
    origin = apply_affine(inverse, 0, 0)
    axes = []
    for px, py in ((1, 0), (0, 1)):
        x, y = apply_affine(inverse, px, py)
        length = ((x - origin[0]) ** 2 + (y - origin[1]) ** 2) ** 0.5
        axes.append(((x - origin[0]) / length, (y - origin[1]) / length))
    (exx, exy), (eyx, eyy) = axes
    distance = eye["distance_mm"]
    corners = [
        (eye["x"] + distance * (t * exx + s * eyx), eye["y"] + distance * (t * exy + s * eyy))
        for t in (frustum["left"], frustum["right"])
        for s in (-frustum["top"], -frustum["bottom"])  # top: up the picture, y down
    ]
    xs, ys = [c[0] for c in corners], [c[1] for c in corners]
    return Rect(min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys))


def neighbours(wall: Wall) -> list[tuple[str, str, str]]:
    """Displays side by side (``x``: b right of a) or one above the other (``y``), with
    nothing between them."""
    found = []
    for a, b in permutations(wall.displays, 2):
        for axis in ("x", "y"):
            near, far = (a.rect.right, b.rect.x) if axis == "x" else (a.rect.bottom, b.rect.y)
            overlap = a.rect.overlap(b.rect)[1 if axis == "x" else 0]
            if far >= near and overlap > 0:
                between = any(
                    c.id not in (a.id, b.id)
                    and (c.rect.x >= near and c.rect.right <= far if axis == "x" else True)
                    and (c.rect.y >= near and c.rect.bottom <= far if axis == "y" else True)
                    and c.rect.overlap(a.rect)[1 if axis == "x" else 0] > 0
                    for c in wall.displays
                )
                if not between:
                    found.append((a.id, b.id, axis))
    return found


def walls() -> list[Wall]:
    shipped = [load_wall(path) for path in wall_files("demo", "irregular")]
    squeezed = dataclasses.replace(shipped[0], bezel_mode="offset")
    return [*shipped, squeezed]


@pytest.mark.parametrize("wall", walls(), ids=lambda w: f"{w.id}-{w.bezel_mode}")
def test_each_display_sees_its_own_rectangle_of_the_one_window(wall: Wall) -> None:
    eye = wall_eye(wall)
    found = frusta(wall, eye)
    for display in wall.displays:
        frustum = found[display.id]
        assert frustum["left"] < frustum["right"] and frustum["bottom"] < frustum["top"]
        seen = window(wall, display.id, frustum, eye)
        scene = wall.viewport(display.id).scene_rect
        for got, want in zip(seen.xywh, scene.xywh, strict=True):
            assert got == pytest.approx(want, abs=MM), (display.id, seen, scene)
        if display.rotation == 0:
            assert frustum["up"] == pytest.approx([0, 1])  # north at the top


@pytest.mark.parametrize("wall", walls(), ids=lambda w: f"{w.id}-{w.bezel_mode}")
def test_the_frusta_tile_the_wall_with_the_bezels_between_them(wall: Wall) -> None:
    """Neighbours' frusta abut across the bezels' share of the window (overlay: what
    the bezels hide, the physical gap; offset: nothing), and together they span the
    whole wall's frustum, edge to edge."""
    eye = wall_eye(wall)
    seen = {d.id: window(wall, d.id, f, eye) for d, f in zip_frusta(wall, eye)}
    pairs = neighbours(wall)
    assert pairs, "the wall has neighbours"
    for a, b, axis in pairs:
        ra, rb = wall.display(a).rect, wall.display(b).rect
        if axis == "x":
            gap, physical = seen[b].x - seen[a].right, rb.x - ra.right
        else:
            gap, physical = seen[b].y - seen[a].bottom, rb.y - ra.bottom
        want = physical if wall.bezel_mode == "overlay" else 0.0
        assert gap == pytest.approx(want, abs=MM), (a, b, axis, gap, physical)
    whole = Rect(
        min(r.x for r in seen.values()),
        min(r.y for r in seen.values()),
        max(r.right for r in seen.values()) - min(r.x for r in seen.values()),
        max(r.bottom for r in seen.values()) - min(r.y for r in seen.values()),
    )
    # the eye stands in front of the middle of the whole window
    assert whole.center == pytest.approx((eye["x"], eye["y"]), abs=MM)


def zip_frusta(wall: Wall, eye: dict[str, float]) -> list[tuple[Any, dict[str, Any]]]:
    found = frusta(wall, eye)
    return [(d, found[d.id]) for d in wall.displays]


def test_a_display_seeing_the_wrong_part_is_caught() -> None:
    """The check above fails for a frustum centred on its display (the bezels and the
    display's place in the wall ignored), as a naive per-display camera would be."""
    wall = load_wall(wall_files("demo")[0])
    eye = wall_eye(wall)
    display = wall.displays[0]
    scene = wall.viewport(display.id).scene_rect
    half_w = scene.width / 2 / eye["distance_mm"]
    half_h = scene.height / 2 / eye["distance_mm"]
    centred = {"left": -half_w, "right": half_w, "top": half_h, "bottom": -half_h}
    seen = window(wall, display.id, centred, eye)
    assert seen.x != pytest.approx(scene.x, abs=MM)


# --- the wall's one camera, turned and tilted (globe.globe_camera) -------------------


def camera_of(heading: float = 0.0, tilt: float = 0.0, view: View | None = None) -> dict[str, Any]:
    wall = load_wall(wall_files("demo")[0])
    geometry = MapGeometry.of(sacramento())
    return globe_camera(geometry, wall, view or View(), heading, tilt)


def enu_at(longitude: float, latitude: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lam, phi = np.radians(longitude), np.radians(latitude)
    east = np.array([-np.sin(lam), np.cos(lam), 0.0])
    north = np.array([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
    return east, north, np.cross(east, north)


def ground(longitude: float, latitude: float) -> np.ndarray:
    lam, phi = np.radians(longitude), np.radians(latitude)
    n = WGS84_A / np.sqrt(1 - WGS84_E2 * np.sin(phi) ** 2)
    return np.array(
        [
            n * np.cos(phi) * np.cos(lam),
            n * np.cos(phi) * np.sin(lam),
            n * (1 - WGS84_E2) * np.sin(phi),
        ]
    )


def test_straight_down_the_camera_stands_over_the_middle_north_up() -> None:
    camera = camera_of()
    target = camera["target"]
    _, north, up = enu_at(target["longitude"], target["latitude"])
    assert camera["longitude"] == pytest.approx(target["longitude"], abs=1e-9)
    assert camera["latitude"] == pytest.approx(target["latitude"], abs=1e-9)
    assert camera["height_m"] == pytest.approx(camera["range_m"], rel=1e-9)
    assert np.allclose(camera["direction"], -up) and np.allclose(camera["up"], north)
    # the position is the geodetic place and height it names
    above = ground(camera["longitude"], camera["latitude"]) + camera["height_m"] * up
    assert np.allclose(camera["position"], above, atol=1e-3)


@pytest.mark.parametrize(("heading", "tilt"), [(0, 30), (90, 0), (90, 45), (225, 60), (359, 10)])
def test_turned_and_tilted_the_camera_still_looks_at_the_middle_from_as_far(
    heading: float, tilt: float
) -> None:
    straight = camera_of()
    camera = camera_of(heading, tilt)
    target = camera["target"]
    assert target == straight["target"] and camera["range_m"] == straight["range_m"]
    east, north, up = enu_at(target["longitude"], target["latitude"])
    position, direction, top = (np.array(camera[k]) for k in ("position", "direction", "up"))
    # the middle of the wall still shows the target, from the same distance
    at = ground(target["longitude"], target["latitude"])
    assert np.allclose(position + camera["range_m"] * direction, at, atol=1e-3)
    # tilted from straight down by `tilt`, towards the heading (clockwise from north)
    assert np.degrees(np.arccos(-direction @ up)) == pytest.approx(tilt, abs=1e-6)
    if tilt:
        along = np.degrees(np.arctan2(direction @ east, direction @ north)) % 360
        assert along == pytest.approx(heading, abs=1e-6)
    # the top of the wall faces the heading; the camera's axes are a right-handed frame
    facing = np.degrees(np.arctan2(top @ east, top @ north)) % 360
    assert facing == pytest.approx(heading, abs=1e-6)
    assert abs(direction @ top) < 1e-12 and np.isclose(np.linalg.norm(top), 1)
    # it stands where it says: lower as it tilts, a little higher than the flat
    # Earth's range cos(tilt) as the Earth curves away under it (d^2 / 2R, some 12 km
    # at the demo's range of about 450 km and 60 degrees), behind the target
    off = camera["range_m"] * np.sin(np.radians(tilt))
    assert camera["height_m"] == pytest.approx(
        camera["range_m"] * np.cos(np.radians(tilt)) + off**2 / (2 * 6.371e6), rel=0.003
    )
    assert np.allclose(
        ground(camera["longitude"], camera["latitude"])
        + camera["height_m"] * enu_at(camera["longitude"], camera["latitude"])[2],
        position,
        atol=1e-3,
    )


def test_a_view_flown_to_a_place_puts_it_under_the_camera() -> None:
    wall = load_wall(wall_files("demo")[0])
    geometry = MapGeometry.of(sacramento())
    u, v = (float(c) for c in geometry.label_points[17])
    view = looking_at(geometry, wall, View(zoom=3), wall_middle(wall), u, v)
    assert view.zoom == 3
    target = globe_camera(geometry, wall, view)["target"]
    assert (target["longitude"], target["latitude"]) == pytest.approx(geometry.to_lonlat(u, v))
    assert projection(geometry, wall, view).point(u, v) == pytest.approx(wall_middle(wall))


# --- where a place of the map appears on the wall under the camera (GlobeProjection) --

CAMERAS = [(0, 0), (30, 45), (90, 0), (225, 60), (359, 10)]


def demo_and_sacramento() -> tuple[Wall, MapGeometry]:
    return load_wall(wall_files("demo")[0]), MapGeometry.of(sacramento())


def offset_place(longitude: float, latitude: float, east_m: float, north_m: float) -> list[float]:
    """A place ``east_m`` east and ``north_m`` north of another (small offsets)."""
    phi = np.radians(latitude)
    n = WGS84_A / np.sqrt(1 - WGS84_E2 * np.sin(phi) ** 2)
    m = n * (1 - WGS84_E2) / (1 - WGS84_E2 * np.sin(phi) ** 2)
    return [
        longitude + np.degrees(east_m / (n * np.cos(phi))),
        latitude + np.degrees(north_m / m),
    ]


@pytest.mark.parametrize(("heading", "tilt"), CAMERAS)
def test_the_camera_s_target_lands_at_the_middle_of_the_wall(heading: float, tilt: float) -> None:
    wall, geometry = demo_and_sacramento()
    view = View(zoom=2)
    seen = globe_projection(geometry, wall, view, heading, tilt)
    target = globe_camera(geometry, wall, view, heading, tilt)["target"]
    u, v = geometry.from_lonlat(target["longitude"], target["latitude"])
    assert seen.point(u, v) == pytest.approx(wall_middle(wall), abs=MM)


@pytest.mark.parametrize(("heading", "tilt"), CAMERAS)
def test_a_place_to_the_camera_s_right_lands_right_of_the_middle(
    heading: float, tilt: float
) -> None:
    """The wall's right, as the top faces ``heading``: east turned by it (straight down,
    north up, east is right; turned to 90, the top faces east and south is right)."""
    wall, geometry = demo_and_sacramento()
    view = View(zoom=2)
    seen = globe_projection(geometry, wall, view, heading, tilt)
    target = globe_camera(geometry, wall, view, heading, tilt)["target"]
    h = np.radians(heading)
    east, north = 5_000 * np.cos(h), -5_000 * np.sin(h)  # 5 km to the right
    place = offset_place(target["longitude"], target["latitude"], east, north)
    at = seen.point(*geometry.from_lonlat(*place))
    assert at is not None
    mx, my = wall_middle(wall)
    assert at[0] - mx > 5, at
    assert abs(at[1] - my) < 0.01 * (at[0] - mx), at  # level with the middle


STRAIGHT_DOWN_SHARE = 0.03
"""How far the straight-down globe puts a place from where the flat map does, as a share
of its distance from the middle of the wall. Measured with the shipped tracts' label
points at zoom 1 and 3: demo at most 2.4 % (25 mm, 40 px, 1.1 m from the middle),
irregular 2.2 %, kl-3x3 1.7 %, hiperwall 2.9 % (91 mm at 3.1 m). The flat map is
equirectangular (x = longitude · cos of the middle latitude), the globe a perspective of
the curved ellipsoid: east-west distances differ by latitude, parallels curve."""


@pytest.mark.parametrize("wall_name", ["demo", "irregular", "kl-3x3", "hiperwall"])
@pytest.mark.parametrize("zoom", [1, 3])
def test_straight_down_the_globe_puts_places_near_where_the_flat_map_does(
    wall_name: str, zoom: float
) -> None:
    wall = load_wall(wall_files(wall_name)[0])
    geometry = MapGeometry.of(sacramento())
    view = View(zoom=zoom)
    flat = projection(geometry, wall, view).points(geometry.label_points)
    globe = globe_projection(geometry, wall, view).points(geometry.label_points)
    shown = ~np.isnan(globe[:, 0])
    assert shown.sum() > 300
    apart = np.hypot(*(globe[shown] - flat[shown]).T)
    from_middle = np.hypot(*(flat[shown] - wall_middle(wall)).T)
    assert np.all(apart <= STRAIGHT_DOWN_SHARE * from_middle + MM), (apart / from_middle).max()
    px = max(1 / d.mm_per_px for d in wall.displays)
    print(f"{wall_name} zoom {zoom}: at most {apart.max():.1f} mm ({apart.max() * px:.0f} px)")


def test_places_behind_the_horizon_or_beyond_the_wall_are_not_placed() -> None:
    wall, geometry = demo_and_sacramento()
    seen = globe_projection(geometry, wall, View(), 0, 60)
    target = globe_camera(geometry, wall, View(), 0, 60)["target"]
    lon, lat = target["longitude"], target["latitude"]
    # the other side of the Earth, and far beyond the horizon ahead (north)
    for place in ([lon + 180, -lat], [lon, lat + 40]):
        u, v = geometry.from_lonlat(*place)
        assert seen.point(u, v) is None
        assert np.isnan(seen.seen(np.array([[u, v]]))).all()
    # behind the camera (south of it, tilted north): not seen either
    camera = globe_camera(geometry, wall, View(), 0, 60)
    behind = geometry.from_lonlat(camera["longitude"], camera["latitude"] - 5)  # 550 km
    assert np.isnan(seen.seen(np.array([behind]))).all()
    # in front and above the horizon, but beyond the wall's edge: seen, not placed
    aside = geometry.from_lonlat(*offset_place(lon, lat, 600_000, 0))
    ((x, _),) = seen.seen(np.array([aside]))
    assert x > wall_window(wall).right and seen.point(*aside) is None
    assert seen.outline(Polygon.from_bounds(*aside, aside[0] + 0.01, aside[1] + 0.01)).is_empty


def test_a_tilted_globe_foreshortens_tracts_far_up_the_wall_and_they_lose_their_codes() -> None:
    """Tilted 60 degrees, tracts in the upper half of the wall lie far off and slanted:
    their room (the widest circle in their outline as the wall shows it) is about half
    what it is straight down, and tracts there that carried their own code straight down
    share a cluster's instead."""
    wall, geometry = demo_and_sacramento()
    wall = dataclasses.replace(wall, id="open", screens={}, stage_ids=())  # all show the map
    minx, miny, maxx, maxy = geometry.extent
    middle = wall_middle(wall)
    view = looking_at(geometry, wall, View(zoom=2), middle, (minx + maxx) / 2, (miny + maxy) / 2)
    straight = globe_projection(geometry, wall, view)
    tilted = globe_projection(geometry, wall, view, 0, 60)
    (_, room), (at, tilted_room) = straight.anchors(geometry), tilted.anchors(geometry)
    shown = ~np.isnan(at[:, 0])
    upper, lower = shown & (at[:, 1] < middle[1] - 100), shown & (at[:, 1] > middle[1] + 100)
    assert upper.sum() > 20 and lower.sum() > 20
    share = tilted_room / np.maximum(room, 1e-9)
    assert np.median(share[upper]) < 0.65 < np.median(share[lower]), (
        np.median(share[upper]),
        np.median(share[lower]),
    )
    side = 40.0
    before = code_anchors(geometry, wall, view, side, mapping=straight)
    after = code_anchors(geometry, wall, view, side, mapping=tilted)
    index = {g: i for i, g in enumerate(geometry.geoids)}
    lost = [
        g for g in before if g not in after and upper[index[g]] and tilted_room[index[g]] < side / 2
    ]
    assert len(lost) >= 10, len(lost)
    # every own code on the tilted globe stands inside its tract as the globe shows it
    for geoid, anchor in after.items():
        outline = tilted.outline(geometry.shapes[index[geoid]])
        assert outline.buffer(0.5).contains(shapely.Point(anchor)), geoid


@pytest.mark.parametrize("wall_name", ["demo", "irregular"])
@pytest.mark.parametrize(("heading", "tilt"), [(0, 0), (30, 45), (200, 60)])
def test_each_display_draws_a_place_at_the_pixel_its_code_is_placed_at(
    wall_name: str, heading: float, tilt: float
) -> None:
    """The cross-check with what tiles draw: ``frustum.js`` (run by Node) gives each
    display its off-centre frustum, turned as ``globe.js`` turns the camera's up for it;
    a place projected through that frustum onto the display's pixels lands where the
    wall's mapping (scene mm, then the display's ``to_pixels``) puts it."""
    wall = load_wall(wall_files(wall_name)[0])
    geometry = MapGeometry.of(sacramento())
    view = View(zoom=2)
    camera = globe_camera(geometry, wall, view, heading, tilt)
    seen = globe_projection(geometry, wall, view, heading, tilt)
    found = frusta(wall, camera["eye"])
    position, direction, wall_up = (np.array(camera[k]) for k in ("position", "direction", "up"))
    right = np.cross(direction, wall_up)
    lonlat = np.array([geometry.to_lonlat(u, v) for u, v in geometry.label_points])
    ground_points = np.array([ground(lon, lat) for lon, lat in lonlat])
    mapped = seen.points(geometry.label_points)
    checked = 0
    for display in wall.displays:
        frustum = found[display.id]
        ur, uu = frustum["up"]
        up = ur * right + uu * wall_up  # globe.js: the picture's up for this display
        picture_right = np.cross(direction, up)  # Cesium: direction x up
        towards = ground_points - position
        depth = towards @ direction
        across, upwards = towards @ picture_right / depth, towards @ up / depth
        width, height = display.resolution
        px = (across - frustum["left"]) / (frustum["right"] - frustum["left"]) * width
        py = (frustum["top"] - upwards) / (frustum["top"] - frustum["bottom"]) * height
        to_pixels = wall.viewport(display.id).to_pixels
        for i in np.flatnonzero((px >= 0) & (px < width) & (py >= 0) & (py < height)):
            assert not np.isnan(mapped[i]).any(), (display.id, i)
            want = apply_affine(to_pixels, *mapped[i])
            assert want == pytest.approx((px[i], py[i]), abs=0.01), (display.id, i)
            checked += 1
    assert checked > 100, checked


def test_tract_boxes_on_the_globe_are_those_of_the_outlines_it_shows() -> None:
    wall, geometry = demo_and_sacramento()
    tilted = globe_projection(geometry, wall, View(zoom=3), 30, 45)
    boxes = tract_boxes(geometry, wall, View(zoom=3), mapping=tilted)
    outlines = [tilted.outline(shape) for shape in geometry.shapes]
    shown = [o for o in outlines if not o.is_empty]
    assert 0 < len(boxes) == len(shown) < len(geometry.shapes)
    for box, outline in zip(boxes, shown, strict=True):
        assert (box.x, box.y, box.right, box.bottom) == pytest.approx(outline.bounds)
        window = wall_window(wall)
        assert window.x <= box.x and box.right <= window.right
        assert window.y <= box.y and box.bottom <= window.bottom
