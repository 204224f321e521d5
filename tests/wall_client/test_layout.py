"""Wall geometry: displays from configs, stages, viewports and their matrices.

How configs are validated and their messages: test_config.py.
"""

from __future__ import annotations

import itertools
import math
import re
from typing import Any

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tests.wall_client.walls import WALLS_DIR, explicit_config, grid_config, panel
from wall_client.config import load_wall, load_walls, parse_wall
from wall_client.layout import (
    IDENTITY,
    Affine,
    Rect,
    Wall,
    apply_affine,
    compose_affine,
    invert_affine,
)

BEZEL_SIDES = ("left", "right", "top", "bottom")
TOL = 1e-6


def close(p: tuple[float, float], q: tuple[float, float], tol: float = TOL) -> bool:
    return math.isclose(p[0], q[0], abs_tol=tol) and math.isclose(p[1], q[1], abs_tol=tol)


# --- grids ---------------------------------------------------------------------------


def test_demo_grid_ids_positions_and_wall_size() -> None:
    wall = load_wall(WALLS_DIR / "demo.toml")
    ids = [d.id for d in wall.displays]
    assert ids == ["r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"]
    pitch_x, pitch_y = 3.5 + 1209.6 + 3.5, 3.5 + 680.4 + 3.5
    for display in wall.displays:
        row, col = (int(n) - 1 for n in re.findall(r"\d+", display.id))
        assert display.rect.x == pytest.approx(col * pitch_x + 3.5)
        assert display.rect.y == pytest.approx(row * pitch_y + 3.5)
        assert (display.rect.width, display.rect.height) == (1209.6, 680.4)
        assert display.resolution == (1920, 1080) and display.rotation == 0
    assert wall.width == pytest.approx(3 * pitch_x)
    assert wall.height == pytest.approx(2 * pitch_y)
    assert wall.nodes() == {"node1": wall.displays}
    assert [d.index for d in wall.displays] == [0, 1, 2, 3, 4, 5]
    assert [d.desktop_origin for d in wall.displays] == [(i * 1920, 0) for i in range(6)]
    assert wall.screens == {"public": ("r1c2",), "menu": ("r1c3",), "registration": ("r2c1",)}
    assert wall.seat_distance_m == 2.0 and wall.bezel_mode == "overlay"
    assert wall.walk_up_distance_m == 0.8


# --- design distances and the stage -------------------------------------------------


def test_each_code_purpose_has_its_design_distance() -> None:
    wall = parse_wall({**grid_config(), "seat_distance_m": 3, "walk_up_distance_m": 0.6})
    assert wall.design_distance_m("seat") == 3.0
    assert wall.design_distance_m("walk-up") == 0.6
    default = parse_wall(grid_config())
    assert (default.seat_distance_m, default.walk_up_distance_m) == (2.0, 0.8)


def test_the_stage_is_the_largest_block_clear_of_the_designated_screens() -> None:
    """The demo's public and menu screens take the top middle and right, registration
    the lower left: a picture framed on the whole wall lies half under them."""
    demo = load_wall(WALLS_DIR / "demo.toml")
    assert demo.stage_ids == ("r2c2", "r2c3")
    r2c2, r2c3 = demo.display("r2c2").rect, demo.display("r2c3").rect
    assert demo.stage == Rect(r2c2.x, r2c2.y, r2c3.right - r2c2.x, r2c2.height)
    kl = load_wall(WALLS_DIR / "kl-3x3.toml")
    assert kl.stage_ids == ("r2c2", "r2c3", "r3c2", "r3c3")
    irregular = load_wall(WALLS_DIR / "irregular.toml")
    assert irregular.stage_ids == ("b2", "b4")  # taller than b3 + b4 is wide
    for wall in (demo, kl, irregular, load_wall(WALLS_DIR / "hiperwall.toml")):
        assert not set(wall.stage_ids) & wall.designated(), wall.id


def test_a_wall_without_screens_frames_on_all_of_it_and_the_stage_can_be_chosen() -> None:
    plain = parse_wall({**grid_config(), "screens": {"registration": []}})
    assert plain.stage_ids == tuple(d.id for d in plain.displays)
    assert plain.stage == Rect(0, 0, plain.width, plain.height)
    chosen = parse_wall({**grid_config(), "screens": {"stage": ["r1c1", "r1c2"]}})
    assert chosen.stage_ids == ("r1c1", "r1c2")
    assert chosen.stage.width == pytest.approx(chosen.display("r1c2").rect.right - 3.5)


def test_bezel_per_side() -> None:
    bezel = {"left": 27, "right": 20, "top": 26, "bottom": 10}
    wall = parse_wall(grid_config(columns=2, rows=2, bezel_mm=bezel, active_mm=[640, 360]))
    pitch_x, pitch_y = 27 + 640 + 20, 26 + 360 + 10
    assert wall.display("r1c1").rect == Rect(27, 26, 640, 360)
    assert wall.display("r2c2").rect == Rect(pitch_x + 27, pitch_y + 26, 640, 360)
    assert (wall.width, wall.height) == (2 * pitch_x, 2 * pitch_y)


def test_gap_between_panels() -> None:
    wall = parse_wall(
        grid_config(columns=3, rows=2, bezel_mm=5, gap_mm=[10, 4], active_mm=[160, 90])
    )
    pitch_x, pitch_y = 5 + 160 + 5 + 10, 5 + 90 + 5 + 4
    assert wall.display("r1c2").rect.x == pytest.approx(pitch_x + 5)
    assert wall.display("r2c1").rect.y == pytest.approx(pitch_y + 5)
    assert wall.width == pytest.approx(3 * pitch_x - 10)
    assert wall.height == pytest.approx(2 * pitch_y - 4)
    same = parse_wall(grid_config(bezel_mm=5, gap_mm=3, active_mm=[160, 90]))
    assert same.display("r2c2").rect.x - same.display("r2c1").rect.right == pytest.approx(13)
    assert same.display("r2c2").rect.y - same.display("r1c2").rect.bottom == pytest.approx(13)


def test_grid_nodes_and_prefix() -> None:
    wall = parse_wall(grid_config(displays_per_node=4, node_prefix="pc"))
    nodes = wall.nodes()
    assert list(nodes) == ["pc1", "pc2"]
    assert [d.id for d in nodes["pc1"]] == ["r1c1", "r1c2", "r1c3", "r2c1"]
    assert [(d.id, d.index) for d in nodes["pc2"]] == [("r2c2", 0), ("r2c3", 1)]


# --- bezel modes ---------------------------------------------------------------------


@st.composite
def grid_walls(draw: st.DrawFn) -> dict[str, Any]:
    w, h = draw(st.sampled_from([(1920, 1080), (2560, 1600), (1080, 1920), (1280, 1024)]))
    active_w = draw(st.floats(50, 1500))
    side = st.floats(0, 60)
    return {
        "id": "prop",
        "bezel_mode": "offset",
        "grid": {
            "columns": draw(st.integers(1, 7)),
            "rows": draw(st.integers(1, 6)),
            "resolution": [w, h],
            "active_mm": [active_w, active_w * h / w],
            "bezel_mm": {s: draw(side) for s in BEZEL_SIDES},
            "gap_mm": [draw(st.floats(0, 30)), draw(st.floats(0, 30))],
            "rotation": draw(st.sampled_from([0, 180])),
        },
    }


@settings(max_examples=150, deadline=None)
@given(grid_walls())
def test_offset_scene_rects_tile_the_scene_exactly(config: dict[str, Any]) -> None:
    wall = parse_wall(config)
    columns, rows = config["grid"]["columns"], config["grid"]["rows"]
    scene = {d.id: wall.viewport(d.id).scene_rect for d in wall.displays}
    tol = 1e-9 * max(wall.width, wall.height)
    for r, c in itertools.product(range(1, rows + 1), range(1, columns + 1)):
        s = scene[f"r{r}c{c}"]
        if c == 1:
            assert s.x == 0
        if c == columns:
            assert math.isclose(s.right, wall.width, abs_tol=tol)
        else:
            assert math.isclose(s.right, scene[f"r{r}c{c + 1}"].x, abs_tol=tol)
        if r == 1:
            assert s.y == 0
        if r == rows:
            assert math.isclose(s.bottom, wall.height, abs_tol=tol)
        else:
            assert math.isclose(s.bottom, scene[f"r{r + 1}c{c}"].y, abs_tol=tol)
    # No overlap beyond rounding, and together they cover the whole scene.
    rects = list(scene.values())
    for a, b in itertools.combinations(rects, 2):
        overlap_w = min(a.right, b.right) - max(a.x, b.x)
        overlap_h = min(a.bottom, b.bottom) - max(a.y, b.y)
        assert overlap_w <= tol or overlap_h <= tol
    area = sum(s.width * s.height for s in rects)
    assert math.isclose(area, wall.width * wall.height, rel_tol=1e-9)


@settings(max_examples=50, deadline=None)
@given(grid_walls())
def test_offset_to_wall_maps_scene_rect_onto_the_display(config: dict[str, Any]) -> None:
    wall = parse_wall(config)
    for display in wall.displays:
        view = wall.viewport(display.id)
        s, r = view.scene_rect, display.rect
        assert close(apply_affine(view.to_wall, s.x, s.y), (r.x, r.y), 1e-6)
        assert close(apply_affine(view.to_wall, s.right, s.bottom), (r.right, r.bottom), 1e-6)


def test_offset_squeezes_bezels_and_margins() -> None:
    config = grid_config(columns=2, rows=1, bezel_mm=10, active_mm=[160, 90])
    config["bezel_mode"] = "offset"
    wall = parse_wall(config)
    # Wall 360 mm wide, 320 covered: each display's scene width is 360 / 2.
    assert wall.viewport("r1c1").scene_rect == Rect(0, 0, 180, 110)
    assert wall.viewport("r1c2").scene_rect.x == pytest.approx(180)
    assert wall.viewport("r1c2").scene_rect.width == pytest.approx(180)


def collinear(points: list[tuple[float, float]]) -> bool:
    (x0, y0), (x1, y1) = points[0], points[-1]
    return all(
        math.isclose((x1 - x0) * (y - y0), (y1 - y0) * (x - x0), abs_tol=1e-6) for x, y in points
    )


def scene_under(wall: Wall, point: tuple[float, float]) -> tuple[float, float]:
    """The scene point a display shows at a physical wall point."""
    for display in wall.displays:
        if display.rect.contains(point):
            return apply_affine(invert_affine(wall.viewport(display.id).to_wall), *point)
    raise AssertionError(f"no display at {point}")


def test_overlay_keeps_lines_straight_across_bezels() -> None:
    wall = load_wall(WALLS_DIR / "demo.toml")
    for display in wall.displays:
        view = wall.viewport(display.id)
        assert view.scene_rect == display.rect and view.to_wall == IDENTITY
    # A physical straight line from r1c1 down-right into r2c3 crosses two bezels.
    start, end = wall.display("r1c1").rect.center, wall.display("r2c3").rect.center
    wall_points = [
        (start[0] + t * (end[0] - start[0]), start[1] + t * (end[1] - start[1]))
        for t in (i / 40 for i in range(41))
    ]
    on_glass = [p for p in wall_points if any(d.rect.contains(p) for d in wall.displays)]
    scene_points = [scene_under(wall, p) for p in on_glass]
    assert all(close(p, q) for p, q in zip(scene_points, on_glass, strict=True))
    assert collinear(scene_points)
    # Offset mode shows the same line kinked: the bezels are squeezed out.
    offset = parse_wall({**grid_config(), "bezel_mode": "offset"})
    assert not collinear([scene_under(offset, p) for p in on_glass])


# --- pixels and rotation -------------------------------------------------------------


def rotated_wall(rotation: int, bezel_mode: str = "overlay") -> Wall:
    w_mm, h_mm = (90, 160) if rotation in (90, 270) else (160, 90)
    return parse_wall(
        explicit_config(
            {**panel("a", 20, 30, rotation=rotation), "width_mm": w_mm, "height_mm": h_mm},
            panel("b", 300, 30),
            bezel_mode=bezel_mode,
        )
    )


# Window corner under the display's wall-side corner (top-left, top-right,
# bottom-right, bottom-left), per rotation; W x H is the native framebuffer.
CORNERS = {
    0: [(0, 0), (1, 0), (1, 1), (0, 1)],
    90: [(0, 1), (0, 0), (1, 0), (1, 1)],
    180: [(1, 1), (0, 1), (0, 0), (1, 0)],
    270: [(1, 0), (1, 1), (0, 1), (0, 0)],
}


@pytest.mark.parametrize("bezel_mode", ["overlay", "offset"])
@pytest.mark.parametrize("rotation", [0, 90, 180, 270])
def test_to_pixels_maps_scene_rect_corners_to_window_corners(
    rotation: int, bezel_mode: str
) -> None:
    wall = rotated_wall(rotation, bezel_mode)
    view = wall.viewport("a")
    assert view.pixels == (1920, 1080)  # the OS does not rotate: always native
    s = view.scene_rect
    wall_corners = [(s.x, s.y), (s.right, s.y), (s.right, s.bottom), (s.x, s.bottom)]
    for corner, (fx, fy) in zip(wall_corners, CORNERS[rotation], strict=True):
        assert close(apply_affine(view.to_pixels, *corner), (fx * 1920, fy * 1080))


@pytest.mark.parametrize("rotation", [0, 90, 180, 270])
def test_rotation_puts_framebuffer_corners_where_the_turned_panel_has_them(
    rotation: int,
) -> None:
    """Derived physically, independently of the table above.

    Name the framebuffer's corners clockwise: top-left, top-right, bottom-right,
    bottom-left. Turning the panel clockwise by k quarter turns moves the corner at
    clockwise position j to wall position (j + k) mod 4; so the wall's top-left corner
    of the display shows framebuffer corner (-k) mod 4, and so on round.
    """
    framebuffer = [(0, 0), (1920, 0), (1920, 1080), (0, 1080)]
    k = rotation // 90
    view = rotated_wall(rotation).viewport("a")
    s = view.scene_rect
    wall_corners = [(s.x, s.y), (s.right, s.y), (s.right, s.bottom), (s.x, s.bottom)]
    for position, corner in enumerate(wall_corners):
        expected = framebuffer[(position - k) % 4]
        assert close(apply_affine(view.to_pixels, *corner), expected)
    # Upright content: the scene's "up" (towards smaller y) points to the framebuffer
    # edge that faces up on the wall.
    up_edge = {0: "top", 90: "left", 180: "bottom", 270: "right"}[rotation]
    x, y = apply_affine(view.to_pixels, s.center[0], s.y)
    side = {(960, 0): "top", (0, 540): "left", (960, 1080): "bottom", (1920, 540): "right"}
    assert side[(round(x), round(y))] == up_edge


@settings(max_examples=200, deadline=None)
@given(
    st.sampled_from([0, 90, 180, 270]),
    st.sampled_from(["overlay", "offset"]),
    st.floats(0, 1),
    st.floats(0, 1),
)
def test_to_pixels_inverse_round_trips(rotation: int, mode: str, u: float, v: float) -> None:
    view = rotated_wall(rotation, mode).viewport("a")
    s = view.scene_rect
    point = (s.x + u * s.width, s.y + v * s.height)
    px = apply_affine(view.to_pixels, *point)
    assert -TOL <= px[0] <= 1920 + TOL and -TOL <= px[1] <= 1080 + TOL
    assert close(apply_affine(invert_affine(view.to_pixels), *px), point)


coefficient = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=300)
@given(st.tuples(*[coefficient] * 6), st.floats(-1e4, 1e4), st.floats(-1e4, 1e4))
def test_apply_and_invert_affine_round_trip(m: Affine, x: float, y: float) -> None:
    a, b, c, d, _, _ = m
    size = max(1.0, abs(a), abs(b), abs(c), abs(d))
    assume(abs(a * d - b * c) > 1e-3 * size**2)  # well conditioned
    inverse = invert_affine(m)
    back = apply_affine(inverse, *apply_affine(m, x, y))
    scale = 1 + abs(x) + abs(y) + max(abs(k) for k in m)
    assert close(back, (x, y), 1e-6 * scale)
    identity = compose_affine(inverse, m)
    assert all(math.isclose(p, q, abs_tol=1e-6) for p, q in zip(identity, IDENTITY, strict=True))


def test_invert_affine_refuses_singular_maps() -> None:
    with pytest.raises(ValueError, match="not invertible"):
        invert_affine((1, 2, 2, 4, 0, 0))


def test_mm_per_px_accounts_for_rotation() -> None:
    wall = rotated_wall(90)
    assert wall.display("a").mm_per_px == pytest.approx(90 / 1080)
    assert wall.display("b").mm_per_px == pytest.approx(160 / 1920)
    assert wall.display("a").mounted_resolution == (1080, 1920)


def test_a_viewport_shows_lines_that_cross_it_or_end_just_outside() -> None:
    """What a display draws of a line: any of it, widened by marks a few pixels wide
    (a pin's head), even when neither end lies on the display."""
    viewport = parse_wall(grid_config()).viewport("r1c2")
    rect = viewport.scene_rect
    reach = viewport.px_to_mm(8)
    assert reach == pytest.approx(8 * 1209.6 / 1920)
    middle = rect.y + rect.height / 2
    assert viewport.shows_segment((rect.right + 50, middle), (rect.x + 50, middle), 8)  # ends on it
    assert viewport.shows_segment((rect.x - 200, middle), (rect.right + 200, middle + 50), 8)
    head_in = (rect.x - reach / 2, middle)  # the head's disc reaches over the edge
    assert viewport.shows_segment((rect.x - 200, middle), head_in, 8)
    assert not viewport.shows_segment((rect.x - 200, middle), (rect.x - 2 * reach, middle), 8)
    below = rect.bottom + 2 * reach  # along the bezel under it
    assert not viewport.shows_segment((rect.x - 200, below), (rect.right + 200, below), 8)
    assert not viewport.shows_segment((rect.x - 100, below + 100), (rect.x - 2 * reach, below), 8)
    assert viewport.shows(Rect(rect.x - 10, rect.y, 30, 30))
    assert not viewport.shows(Rect(rect.x - 40, rect.y, 30, 30))


# --- explicit form -------------------------------------------------------------------


def test_explicit_displays_default_nodes_indices_and_desktop_origins() -> None:
    wall = parse_wall(
        explicit_config(
            {**panel("p", 0, 0, rotation=270, node="left"), "width_mm": 90, "height_mm": 160},
            panel("a", 100, 0, node="left"),
            panel("b", 270, 0, node="right"),
            panel("c", 100, 100, node="left", desktop_origin=[0, 1080]),
            panel("d", 270, 100, resolution=[3840, 2160]),
            panel("e", 440, 0),
        )
    )
    d = {display.id: display for display in wall.displays}
    assert [(d[i].node, d[i].index) for i in "pabcde"] == [
        ("left", 0),
        ("left", 1),
        ("right", 0),
        ("left", 2),
        ("node1", 0),
        ("node1", 1),
    ]
    # Side by side at native width (the OS does not rotate the portrait panel).
    assert d["p"].desktop_origin == (0, 0)
    assert d["a"].desktop_origin == (1920, 0)
    assert d["b"].desktop_origin == (0, 0)
    assert d["c"].desktop_origin == (0, 1080)  # explicit
    assert d["e"].desktop_origin == (3840, 0)
    assert [x.id for x in wall.nodes()["left"]] == ["p", "a", "c"]
    assert list(wall.nodes()) == ["left", "right", "node1"]
    assert (wall.width, wall.height) == (600, 190)


def test_explicit_index_orders_nodes_and_origins() -> None:
    wall = parse_wall(
        explicit_config(
            panel("a", 0, 0, index=1),
            panel("b", 200, 0, resolution=[1280, 720], width_mm=160, index=0),
        )
    )
    assert [x.id for x in wall.nodes()["node1"]] == ["b", "a"]
    assert wall.display("a").desktop_origin == (1280, 0)
    assert wall.display("b").desktop_origin == (0, 0)


def test_registration_defaults_to_the_lower_left_display() -> None:
    wall = parse_wall(
        explicit_config(
            panel("high", 0, 0),
            panel("low-right", 400, 100),
            panel("low-left", 200, 100),
            screens={"public": "high"},
        )
    )
    assert wall.screens == {"public": ("high",), "menu": (), "registration": ("low-left",)}
    assert [x.id for x in wall.screen("registration")] == ["low-left"]
    assert wall.screen("menu") == ()
    assert parse_wall(grid_config()).screens["registration"] == ("r2c1",)
    none = parse_wall({**grid_config(), "screens": {"registration": []}})
    assert none.screens["registration"] == ()
    with pytest.raises(KeyError, match="lobby"):
        wall.screen("lobby")


def test_screens_accept_lists() -> None:
    wall = parse_wall({**grid_config(), "screens": {"public": ["r1c1", "r1c2"]}})
    assert [x.id for x in wall.screen("public")] == ["r1c1", "r1c2"]


def test_wall_size_can_leave_margins() -> None:
    wall = parse_wall({**grid_config(), "wall": {"width_mm": 4000, "height_mm": 1500}})
    assert (wall.width, wall.height) == (4000, 1500)
    wall = parse_wall({**grid_config(), "wall": {"height_mm": 1500}})
    assert wall.width == pytest.approx(3 * 1216.6)


def test_display_lookup_errors_name_the_wall() -> None:
    wall = parse_wall(grid_config())
    with pytest.raises(KeyError, match=r"wall 'test' has no display 'r9c9'"):
        wall.display("r9c9")
    with pytest.raises(KeyError, match="r9c9"):
        wall.viewport("r9c9")
    assert list(wall.viewports()) == [d.id for d in wall.displays]
    assert wall.viewports()["r1c1"] is wall.viewport("r1c1")  # computed once


def test_rect_geometry() -> None:
    a = Rect(0, 0, 10, 10)
    assert (a.right, a.bottom, a.center) == (10, 10, (5, 5))
    assert a.intersects(Rect(5, 5, 10, 10))
    assert not a.intersects(Rect(10, 0, 5, 5))  # touching edges
    assert not a.intersects(Rect(0, 10, 5, 5))
    assert not a.intersects(Rect(5, 5, 0, 3))  # no area
    assert a.contains(Rect(0, 0, 10, 10)) and a.contains(Rect(2, 2, 3, 3))
    assert not a.contains(Rect(8, 8, 3, 3))
    assert a.contains((10, 0)) and not a.contains((10.1, 0))


# --- shipped walls -------------------------------------------------------------------


def test_every_shipped_wall_loads() -> None:
    walls = load_walls([WALLS_DIR])
    assert set(walls) == {"demo", "kl-3x3", "hiperwall", "irregular"}
    assert len(walls["kl-3x3"].displays) == 9
    hiperwall = walls["hiperwall"]
    assert len(hiperwall.displays) == 50
    megapixels = sum(d.resolution[0] * d.resolution[1] for d in hiperwall.displays) / 1e6
    assert megapixels == pytest.approx(204.8)
    assert hiperwall.display("r1c1").rect == Rect(33, 30, 641.3, 400.8)
    for wall in walls.values():
        assert wall.source is not None and wall.source.parent == WALLS_DIR
        assert wall.screens["registration"], wall.id
        for display in wall.displays:
            assert Rect(0, 0, wall.width, wall.height).contains(display.rect)


def test_irregular_wall_has_a_portrait_panel() -> None:
    wall = load_wall(WALLS_DIR / "irregular.toml")
    portrait = [d for d in wall.displays if d.rotation in (90, 270)]
    assert len(portrait) == 1 and portrait[0].rect.height > portrait[0].rect.width
    assert wall.screens["registration"] == (portrait[0].id,)
    assert len(wall.screens["public"]) == 1
    assert wall.display(wall.screens["public"][0]).rotation == 0
    pitches = {round(d.mm_per_px, 3) for d in wall.displays}
    assert pitches == {0.63, 0.49}


def test_a_wall_tells_a_moment_in_its_time_zone() -> None:
    from datetime import UTC, datetime

    from tests.wall_client.walls import grid_config
    from wall_client.config import parse_wall

    wall = parse_wall({**grid_config(), "time_zone": "America/Los_Angeles"}, "x.toml")
    noon = datetime(2026, 11, 27, 12, 0, tzinfo=UTC)
    assert wall.local_time(noon).isoformat() == "2026-11-27T04:00:00-08:00"
