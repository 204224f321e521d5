"""Each display's part of the wall's one camera, as ``static/frustum.js`` computes it
(run by Node, the one home of the rule), against the wall's geometry here: the displays'
frusta tile the wall's window exactly, the bezels' share between neighbours."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from itertools import permutations
from typing import Any

import numpy as np
import pytest

from tests.conftest import wall_files
from tests.webapp.apps.census_map.conftest import sacramento
from wall_client.config import load_wall
from wall_client.layout import Rect, Wall, apply_affine, invert_affine
from webapp.apps.census_map.earth import WGS84_A, WGS84_E2
from webapp.apps.census_map.globe import globe_camera, wall_eye, wall_middle
from webapp.apps.census_map.mapview import MapGeometry, looking_at, projection
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
