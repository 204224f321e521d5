"""Placement: every code inside one display, free of others, near its anchor."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tag_service.placement import (
    SPREAD_OF_SIDE,
    Layout,
    Mark,
    PinConflict,
    Placement,
    PlacementRequest,
    _crosses,
    caption_height,
    marks_of,
    pin_conflicts,
    place,
    place_box,
)
from tag_service.sizing import min_module_mm, symbol_modules
from wall_client.config import load_wall
from wall_client.layout import ROLES, Rect, Wall

WALLS = Path(__file__).resolve().parents[2] / "content" / "walls"
V2 = symbol_modules(25)  # 33 modules across with the quiet zone
V1 = symbol_modules(21)
TOL = 1e-6  # mm: float rounding of pixel edges


def grown(rect: Rect, margin: float) -> Rect:
    return Rect(rect.x - margin, rect.y - margin, rect.width + 2 * margin, rect.height + 2 * margin)


@pytest.fixture(scope="module")
def demo() -> Wall:
    return load_wall(WALLS / "demo.toml")


def load(name: str) -> Wall:
    return load_wall(WALLS / f"{name}.toml")


def anchored(
    key: str, x: float, y: float, distance_m: float = 2.0, **kw: object
) -> PlacementRequest:
    return PlacementRequest(
        key=key, sizes=(V2,), module_mm=min_module_mm(distance_m), anchor=(x, y), **kw
    )


def clear_square(request: PlacementRequest) -> Rect | None:
    """The square a request keeps free of codes (None without a clearance)."""
    if request.anchor is None or request.clear_mm <= 0:
        return None
    (x, y), c = request.anchor, request.clear_mm
    return Rect(x - c, y - c, 2 * c, 2 * c)


def designated(wall: Wall) -> set[str]:
    return {d.id for role in ROLES for d in wall.screen(role)}


def assert_valid(
    wall: Wall, requests: list[PlacementRequest], reserved: list[Rect], layout: Layout
) -> None:
    """The rules of :mod:`tag_service.placement`, checked on any outcome."""
    placed = {p.key: p for p in layout.placed}
    unplaced = {u.key for u in layout.unplaced}
    assert placed.keys().isdisjoint(unplaced)
    assert placed.keys() | unplaced == {r.key for r in requests}, "nothing is dropped"
    assert all(u.reason for u in layout.unplaced)
    by_key = {r.key: r for r in requests}
    squares = [square for r in requests if (square := clear_square(r)) is not None]
    for p in layout.placed:
        request = by_key[p.key]
        display = wall.display(p.display_id)
        scene = wall.viewport(p.display_id).scene_rect
        x, y, side = p.pixels
        width, height = display.mounted_resolution
        assert 0 <= x <= width - side and 0 <= y <= height - side
        assert grown(scene, TOL).contains(p.rect), "wholly inside one display"
        assert side == p.modules * p.px_per_module and p.px_per_module >= 3
        assert p.modules == request.sizes[p.variant]
        assert p.px_per_module * display.mm_per_px >= request.module_mm * 0.999
        assert not any(p.rect.intersects(area) for area in reserved)
        if request.anchor is not None:
            assert p.display_id not in designated(wall), "panels keep their screens"
            assert not any(p.rect.intersects(grown(sq, -TOL)) for sq in squares), "pins clear"
            inside = p.footprint.contains(request.anchor) and request.clear_mm == 0
            assert (p.leader is None) == inside
            if p.leader is not None:
                start, end = p.leader
                assert end == request.anchor
                assert grown(p.footprint, TOL).contains(start), "pins start at the footprint"
        else:
            assert p.leader is None
            assert p.display_id in {d.id for d in wall.screen(str(request.screen))}
        if request.caption:
            assert p.caption is not None and p.caption_pixels is not None
            assert grown(scene, TOL).contains(p.caption), "a caption is never cut off"
            assert p.caption.y == pytest.approx(p.rect.bottom), "right under its code"
            _, cy, cw, ch = p.caption_pixels
            assert cw >= side and ch == caption_height(side) and cy == y + side
        else:
            assert p.caption is None
    assert pin_conflicts(marks_of(layout)) == [], "pins never cross"
    anchors = [(r.key, r.anchor) for r in requests if r.anchor is not None]
    for p in layout.placed:
        hidden = [k for k, a in anchors if k != p.key and grown(p.footprint, -TOL).contains(a)]
        if by_key[p.key].anchor is not None:
            assert not hidden, f"{p.key} covers the anchors of {hidden}"
    for a, b in itertools.combinations(layout.placed, 2):
        if a.display_id == b.display_id:
            assert not boxes_overlap(pixel_box(a), pixel_box(b)), (a, b)
            if by_key[a.key].anchor is not None and by_key[b.key].anchor is not None:
                gap = math.ceil(SPREAD_OF_SIDE * min(a.pixels[2], b.pixels[2]))
                assert not boxes_overlap(pixel_box(a, gap), pixel_box(b)), "spread apart"


def by_key(requests: list[PlacementRequest]) -> dict[str, PlacementRequest]:
    return {r.key: r for r in requests}


def pixel_box(p: Placement, margin: int = 0) -> tuple[int, int, int, int]:
    """A code with its caption in its display's pixels (x0, y0, x1, y1), grown by
    ``margin`` on every side."""
    x, y, side = p.pixels
    x0, y0, x1, y1 = x, y, x + side, y + side
    if p.caption_pixels is not None:
        cx, cy, cw, ch = p.caption_pixels
        x0, x1, y1 = min(x0, cx), max(x1, cx + cw), cy + ch
    return (x0 - margin, y0 - margin, x1 + margin, y1 + margin)


def boxes_overlap(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


@st.composite
def scenarios(draw: st.DrawFn) -> tuple[Wall, list[PlacementRequest], list[Rect]]:
    wall = draw(st.sampled_from([load("demo"), load("irregular"), load("kl-3x3")]))
    distance = draw(st.floats(0.3, 4.0))
    count = draw(st.integers(0, 40))
    requests = []
    for index in range(count):
        x = draw(st.floats(-100, wall.width + 100))
        y = draw(st.floats(-100, wall.height + 100))
        sizes = draw(st.sampled_from([(V2,), (V2, V1), (V1,)]))
        preferred = draw(st.none() | st.floats(20, 400))
        clear = draw(st.sampled_from([0.0, 0.0, 0.0, 5.0, 60.0, 400.0]))
        requests.append(
            PlacementRequest(
                key=f"T{index}",
                sizes=sizes,
                module_mm=min_module_mm(distance),
                anchor=(x, y),
                preferred_mm=preferred,
                clear_mm=clear,
                caption=draw(st.booleans()),
            )
        )
    for slot in range(draw(st.integers(0, 6))):
        role = draw(st.sampled_from(ROLES))
        requests.append(
            PlacementRequest(
                key=f"S{slot}",
                sizes=(V2,),
                module_mm=min_module_mm(distance),
                screen=role,
                slot=slot,
                caption=draw(st.booleans()),
            )
        )
    reserved = [
        Rect(
            draw(st.floats(0, wall.width)),
            draw(st.floats(0, wall.height)),
            draw(st.floats(1, 800)),
            draw(st.floats(1, 800)),
        )
        for _ in range(draw(st.integers(0, 3)))
    ]
    return wall, requests, reserved


@settings(max_examples=60, deadline=None)
@given(scenarios())
def test_any_layout_keeps_the_rules(
    scenario: tuple[Wall, list[PlacementRequest], list[Rect]],
) -> None:
    wall, requests, reserved = scenario
    layout = place(wall, requests, reserved)
    assert_valid(wall, requests, reserved, layout)
    assert place(wall, requests, reserved) == layout, "deterministic"


def test_a_code_stands_centred_on_its_anchor_when_there_is_room(demo: Wall) -> None:
    scene = demo.viewport("r1c1").scene_rect
    layout = place(demo, [anchored("A", *scene.center)])
    [code] = layout.placed
    assert code.display_id == "r1c1" and code.leader is None
    cx, cy = code.rect.center
    assert abs(cx - scene.center[0]) <= code.rect.width / code.pixels[2]
    assert abs(cy - scene.center[1]) <= code.rect.height / code.pixels[2]


def test_an_anchor_on_a_bezel_gets_a_code_beside_it_with_a_pin(demo: Wall) -> None:
    left = demo.viewport("r2c2").scene_rect
    anchor = (left.right + 1.0, left.center[1])  # in the bezel between r2c2 and r2c3
    layout = place(demo, [anchored("A", *anchor)])
    [code] = layout.placed
    assert code.display_id in {"r2c2", "r2c3"}
    assert code.leader is not None and code.leader[1] == anchor
    assert_valid(demo, [anchored("A", *anchor)], [], layout)


def test_crowded_codes_move_apart_and_point_back(demo: Wall) -> None:
    centre = demo.viewport("r2c2").scene_rect.center
    requests = [anchored(f"A{i}", *centre, distance_m=0.8, caption=True) for i in range(5)]
    layout = place(demo, requests)
    assert len(layout.placed) == 5
    # none sits on the anchor: it would hide the others' pin heads there
    assert all(p.leader is not None and p.leader[1] == centre for p in layout.placed)
    assert_valid(demo, requests, [], layout)


def test_codes_keep_off_designated_screens(demo: Wall) -> None:
    public = demo.screen("public")[0]
    anchor = demo.viewport(public.id).scene_rect.center
    [code] = place(demo, [anchored("A", *anchor)]).placed
    assert code.display_id != public.id


def test_a_reserved_panel_pushes_codes_aside(demo: Wall) -> None:
    scene = demo.viewport("r2c2").scene_rect
    panel = Rect(scene.x, scene.y, scene.width, scene.height / 2)
    request = anchored("A", scene.center[0], scene.y + 10)
    [code] = place(demo, [request], [panel]).placed
    assert not code.rect.intersects(panel)
    assert code.leader is not None


def test_the_smaller_variant_is_used_when_the_preferred_one_does_not_fit(demo: Wall) -> None:
    # At 6.7 m a module is ~22 mm: a version-2 symbol (33 across) is taller than a
    # 680 mm panel, a version-1 symbol (29 across) is not.
    module = min_module_mm(6.7)
    centre = demo.viewport("r2c2").scene_rect.center
    request = PlacementRequest(key="A", sizes=(V2, V1), module_mm=module, anchor=centre)
    [code] = place(demo, [request]).placed
    assert (code.variant, code.modules) == (1, V1)
    only_v2 = PlacementRequest(key="B", sizes=(V2,), module_mm=module, anchor=centre)
    [problem] = place(demo, [only_v2]).unplaced
    assert problem.reason.startswith("display too small")


def test_a_code_too_big_for_any_display_is_reported(demo: Wall) -> None:
    request = anchored("BIG", 100, 100, distance_m=40.0)
    layout = place(demo, [request])
    [problem] = layout.unplaced
    assert problem.key == "BIG" and problem.reason.startswith("display too small")


def test_no_space_near_the_anchor_is_reported(demo: Wall) -> None:
    everything = Rect(-10, -10, demo.width + 20, demo.height + 20)
    layout = place(demo, [anchored("A", 500, 300)], [everything])
    [problem] = layout.unplaced
    assert problem.reason.startswith("no space within") and "(500.0, 300.0)" in problem.reason


def test_slot_codes_share_their_screen_in_reading_order(demo: Wall) -> None:
    module = min_module_mm(demo.seat_distance_m)
    requests = [
        PlacementRequest(key=k, sizes=(V2,), module_mm=module, screen="registration", slot=s)
        for k, s in [("second", 1), ("first", 0)]
    ]
    layout = place(demo, requests)
    first, second = sorted(layout.placed, key=lambda p: p.rect.x)
    assert (first.key, second.key) == ("first", "second")
    assert {p.display_id for p in layout.placed} == {"r2c1"}
    assert [p.key for p in layout.placed] == ["second", "first"], "results keep request order"


def test_a_missing_screen_is_reported() -> None:
    wall = load("irregular")
    missing = [role for role in ROLES if not wall.screen(role)]
    assert missing == ["menu"]
    request = PlacementRequest(key="S", sizes=(V2,), module_mm=1.0, screen=missing[0])
    [problem] = place(wall, [request]).unplaced
    assert problem.reason == f"wall has no {missing[0]!r} screen"


def test_a_crowded_screen_says_how_many_codes_did_not_fit(demo: Wall) -> None:
    module = min_module_mm(demo.seat_distance_m)
    requests = [
        PlacementRequest(key=f"S{i}", sizes=(V2,), module_mm=module, screen="menu", slot=i)
        for i in range(200)
    ]
    layout = place(demo, requests)
    assert layout.placed and layout.unplaced
    assert "menu screen (r1c3) has no room for 200 codes" in layout.unplaced[0].reason
    assert_valid(demo, requests, [], layout)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"anchor": None}, "give either an anchor or a screen slot"),
        ({"screen": "public"}, "give either an anchor or a screen slot"),
        ({"anchor": None, "screen": "lobby"}, "unknown screen 'lobby'"),
        ({"sizes": ()}, "sizes must be positive"),
        ({"module_mm": 0.0}, "module_mm must be positive"),
        ({"clear_mm": -1.0}, "clear_mm must be a finite distance"),
        ({"clear_mm": float("nan")}, "clear_mm must be a finite distance"),
        ({"anchor": None, "screen": "menu", "clear_mm": 5.0}, "clear_mm needs an anchor"),
    ],
)
def test_malformed_requests_are_refused(kwargs: dict[str, object], message: str) -> None:
    fields: dict[str, object] = {"key": "X", "sizes": (V2,), "module_mm": 1.0, "anchor": (0.0, 0.0)}
    with pytest.raises(ValueError, match=message):
        PlacementRequest(**{**fields, **kwargs})  # type: ignore[arg-type]


def test_duplicate_keys_are_refused(demo: Wall) -> None:
    with pytest.raises(ValueError, match="unique keys"):
        place(demo, [anchored("A", 10, 10), anchored("A", 20, 20)])


def test_a_cleared_anchor_gets_its_code_beside_it_on_a_pin(demo: Wall) -> None:
    anchor = demo.viewport("r1c1").scene_rect.center
    request = anchored("A", *anchor, clear_mm=80.0)
    layout = place(demo, [request])
    [code] = layout.placed
    square = clear_square(request)
    assert square is not None
    assert not code.rect.intersects(grown(square, -TOL)), "wholly outside its square"
    assert code.leader is not None
    start, end = code.leader
    assert end == anchor
    assert grown(code.rect, TOL).contains(start)
    assert start[0] in (code.rect.x, code.rect.right) or start[1] in (
        code.rect.y,
        code.rect.bottom,
    ), "the pin starts on the code's edge"
    # Nearest outside the square: flush with one side (give or take the pixels the
    # square was rounded out to), centred on the anchor along it.
    pixel = code.rect.width / code.pixels[2]
    cx, cy = code.rect.center
    beside = 80.0 + code.rect.width / 2
    assert max(abs(cx - anchor[0]), abs(cy - anchor[1])) <= beside + 2 * pixel
    assert min(abs(cx - anchor[0]), abs(cy - anchor[1])) <= pixel
    assert_valid(demo, [request], [], layout)


def test_no_code_covers_another_tags_cleared_anchor(demo: Wall) -> None:
    anchor = demo.viewport("r2c2").scene_rect.center
    pinned = anchored("PIN", *anchor, clear_mm=60.0)
    # Anchored right beside the pin head and placed first: the square is kept anyway.
    neighbours = [anchored(f"N{i}", anchor[0] + 10 * i, anchor[1] - 5) for i in range(4)]
    requests = [*neighbours, pinned]
    layout = place(demo, requests)
    assert len(layout.placed) == len(requests)
    square = clear_square(pinned)
    assert square is not None
    assert all(not p.rect.intersects(grown(square, -TOL)) for p in layout.placed)
    assert all(p.leader is not None for p in layout.placed), "every anchor is inside it"
    assert_valid(demo, requests, [], layout)


def test_no_clearance_places_as_before(demo: Wall) -> None:
    centre = demo.viewport("r2c2").scene_rect.center
    plain = [anchored(f"A{i}", centre[0] + 300 * i, centre[1]) for i in range(4)]
    zero = [anchored(f"A{i}", centre[0] + 300 * i, centre[1], clear_mm=0.0) for i in range(4)]
    layout = place(demo, plain)
    assert place(demo, zero) == layout
    assert layout.placed[0].leader is None, "the first still sits on its anchor"


def test_a_clearance_beyond_the_reach_still_places_the_code(demo: Wall) -> None:
    # The square covers almost all of r2c2: the code goes to the next free display,
    # further than 3 code sides from the anchor but within 3 sides of the square.
    anchor = demo.viewport("r2c2").scene_rect.center
    request = anchored("A", *anchor, clear_mm=600.0)
    layout = place(demo, [request])
    [code] = layout.placed
    side = code.rect.width
    distance = math.dist(code.rect.center, anchor)
    assert 3 * side < distance <= 3 * side + 600.0
    assert code.leader is not None and code.leader[1] == anchor
    assert_valid(demo, [request], [], layout)


def test_cleared_layouts_are_deterministic(demo: Wall) -> None:
    centre = demo.viewport("r2c3").scene_rect.center
    requests = [
        anchored(f"A{i}", centre[0] + 30 * (i % 3), centre[1] + 25 * (i // 3), clear_mm=c)
        for i, c in enumerate([40.0, 0.0, 15.0, 90.0, 0.0, 25.0])
    ]
    reserved = [Rect(centre[0] - 300, centre[1] + 150, 200, 100)]
    layout = place(demo, requests, reserved)
    assert place(demo, requests, reserved) == layout
    assert_valid(demo, requests, reserved, layout)


# --- pins never cross ----------------------------------------------------------------

SQUARE = Rect(0, 0, 10, 10)


def mark(key: str, footprint: Rect, head: tuple[float, float] | None = None) -> Mark:
    """A code on ``footprint`` with a pin from its nearest point to ``head``."""
    if head is None:
        return Mark(key, footprint, None)
    edge = (
        min(max(head[0], footprint.x), footprint.right),
        min(max(head[1], footprint.y), footprint.bottom),
    )
    return Mark(key, footprint, (edge, head))


def test_two_pins_that_cross_are_found() -> None:
    a = mark("A", Rect(0, 0, 10, 10), (40, 40))  # from (10, 10) down to the right
    b = mark("B", Rect(30, 0, 10, 10), (5, 40))  # from (30, 10) down to the left
    assert [str(c) for c in pin_conflicts([a, b])] == ["the pins of A and B cross"]
    apart = mark("B", Rect(30, 0, 10, 10), (60, 40))
    assert pin_conflicts([a, apart]) == []


def test_pins_meeting_only_at_a_shared_head_do_not_cross_but_one_along_another_does() -> None:
    a = mark("A", Rect(0, 0, 10, 10), (20, 20))
    b = mark("B", Rect(30, 0, 10, 10), (20, 20))
    assert pin_conflicts([a, b]) == []
    along = mark("C", Rect(30, 30, 10, 10), (15, 15))  # back along the same diagonal
    assert [c.kind for c in pin_conflicts([a, along])] == ["crossing"]


def test_a_pin_under_a_code_is_found_whichever_stood_first() -> None:
    pinned = mark("A", Rect(0, 0, 10, 10), (50, 5))  # runs right, under B
    code = mark("B", Rect(20, 0, 10, 10))
    expected = [PinConflict("pin under code", "A", "B")]
    assert pin_conflicts([pinned, code]) == expected
    assert pin_conflicts([code, pinned]) == expected
    below = mark("A", Rect(0, 0, 10, 10), (50, 30))  # passes under B's corner: clear
    assert pin_conflicts([below, code]) == []


def test_a_pin_head_under_a_code_is_found() -> None:
    pinned = mark("A", Rect(0, 0, 10, 10), (25, 25))
    code = mark("B", Rect(20, 20, 10, 10))
    found = pin_conflicts([code, pinned])
    assert PinConflict("head under code", "A", "B") in found
    touching = mark("A", Rect(0, 0, 10, 10), (20, 25))  # on B's edge: still seen
    assert pin_conflicts([code, touching]) == []


def test_no_code_stands_over_another_tags_anchor(demo: Wall) -> None:
    """Census cluster codes stood on a neighbour's anchor: its code then pointed at a
    head under the cluster's code."""
    centre = demo.viewport("r2c2").scene_rect.center
    first = anchored("A", *centre)
    neighbour = anchored("B", centre[0] + 30, centre[1] + 20)
    layout = place(demo, [first, neighbour])
    assert len(layout.placed) == 2
    assert all(p.leader is not None for p in layout.placed), "neither covers the other's"
    assert pin_conflicts(marks_of(layout)) == []
    assert_valid(demo, [first, neighbour], [], layout)


def test_pins_of_a_crowd_go_round_each_other(demo: Wall) -> None:
    """Deep brain structures: a dozen heads in a hand's width, each kept clear, placed
    in order; no pin crosses another or runs under a code, and a code that finds no
    such spot says so."""
    centre = demo.viewport("r2c2").scene_rect.center
    requests = [
        anchored(f"P{i}", centre[0] + 40 * math.cos(i * 2.4), centre[1] + 30 * math.sin(i * 1.7),
                 distance_m=0.8, clear_mm=40.0, caption=True)
        for i in range(12)
    ]  # fmt: skip
    layout = place(demo, requests)
    assert pin_conflicts(marks_of(layout)) == []
    assert all("pin" in u.reason for u in layout.unplaced)
    assert len(layout.placed) >= 8
    assert_valid(demo, requests, [], layout)


# --- captions and spreading -----------------------------------------------------------


def test_a_caption_near_the_bottom_edge_moves_its_code_up_instead_of_being_cut(
    demo: Wall,
) -> None:
    """Zoomed-in census codes near a display's bottom edge lost their tract number."""
    scene = demo.viewport("r2c2").scene_rect
    request = anchored("A", scene.center[0], scene.bottom - 5, distance_m=0.8, caption=True)
    [code] = place(demo, [request]).placed
    assert code.caption is not None and code.caption.bottom <= scene.bottom + TOL
    assert code.caption.y == pytest.approx(code.rect.bottom)
    assert code.caption.width == pytest.approx(code.rect.width)
    assert code.rect.center[1] < request.anchor[1] if request.anchor else False
    assert_valid(demo, [request], [], layout=place(demo, [request]))


def test_menu_captions_stay_in_their_cells_on_every_shipped_wall() -> None:
    """HIPerWall's menu captions ran off the left edge and over each other."""
    for name in ("demo", "hiperwall", "kl-3x3"):
        wall = load(name)
        requests = [
            PlacementRequest(
                key=f"M{slot}",
                sizes=(V2,),
                module_mm=min_module_mm(wall.seat_distance_m),
                screen="menu",
                slot=slot,
                caption=True,
            )
            for slot in range(10)
        ]
        layout = place(wall, requests)
        assert not layout.unplaced, (name, layout.unplaced)
        assert_valid(wall, requests, [], layout)


def test_codes_marking_neighbouring_points_are_spread_apart(demo: Wall) -> None:
    """Deep brain views packed four to six codes edge to edge."""
    x, y = demo.viewport("r2c2").scene_rect.center
    requests = [
        anchored(f"P{i}", x + 20 * i, y, distance_m=0.8, caption=True, clear_mm=40)
        for i in range(5)
    ]
    layout = place(demo, requests)
    assert len(layout.placed) == 5
    assert_valid(demo, requests, [], layout)
    for code in layout.placed:
        assert math.dist(code.rect.center, by_key(requests)[code.key].anchor or (0, 0)) < 400


# --- boxes (balloons) ---------------------------------------------------------------

ANCHOR = (1800.0, 1000.0)  # on r2c2 of the demo wall, a display free for boxes
BARS = [Rect(1700, 1015, 200, 10), Rect(1700, 975, 200, 10)]  # codes above and below it


def pointer_crosses(box: Rect, anchor: tuple[float, float], rects: list[Rect]) -> bool:
    """Whether the line from the box's nearest point to ``anchor`` enters any rect (by
    sampling it densely: independent of the slab method placement uses)."""
    ax, ay = anchor
    ex, ey = min(max(ax, box.x), box.right), min(max(ay, box.y), box.bottom)
    for t in np.linspace(0.0, 1.0, 2001):
        x, y = ex + t * (ax - ex), ey + t * (ay - ey)
        if any(r.x < x < r.right and r.y < y < r.bottom for r in rects):
            return True
    return False


def test_a_box_stands_nearest_its_anchor_clear_of_obstacles_and_the_square(demo: Wall) -> None:
    box = place_box(demo, (200, 100), ANCHOR, BARS, clear_mm=10)
    assert box is not None
    assert not any(box.intersects(bar) for bar in BARS)
    assert not box.intersects(Rect(1790, 990, 20, 20))
    assert math.dist(box.center, ANCHOR) == pytest.approx(75, abs=1)
    assert pointer_crosses(box, ANCHOR, BARS), "the nearest spot points across a bar"


def test_with_sight_its_pointer_crosses_none_of_them(demo: Wall) -> None:
    box = place_box(demo, (200, 100), ANCHOR, BARS, clear_mm=10, sight=BARS)
    assert box is not None
    assert not any(box.intersects(bar) for bar in BARS)
    assert not pointer_crosses(box, ANCHOR, BARS)
    assert math.dist(box.center, ANCHOR) == pytest.approx(200, abs=1), "out between the bars"


@pytest.mark.parametrize(
    ("start", "end", "crosses"),
    [
        ((0, 5), (20, 5), True),  # straight through
        ((5, 5), (5, 5), True),  # a point inside
        ((0, 10), (10, 0), True),  # corner to corner, across the inside
        ((-5, 0), (20, 0), False),  # along the top edge
        ((5, -5), (5, 0), False),  # ends on the edge
        ((0, 20), (20, 0), False),  # touches the corner (10, 10) only
        ((11, -5), (11, 20), False),  # beside it
    ],
)
def test_which_pointers_cross_a_rectangle(
    start: tuple[float, float], end: tuple[float, float], crosses: bool
) -> None:
    """Only the inside of the rectangle (0, 0)-(10, 10) blocks: touching is fine
    (obstacles are grown by what a line needs)."""
    rect = np.array([[0.0, 0.0, 10.0, 10.0]])
    found = _crosses(np.array([start], dtype=float), np.array([end], dtype=float), rect)
    assert bool(found[0]) == crosses


def test_no_line_clear_of_the_sight_obstacles_means_no_box(demo: Wall) -> None:
    ring = [Rect(1770, 960, 60, 5), Rect(1770, 1035, 60, 5), Rect(1765, 960, 5, 80),
            Rect(1830, 960, 5, 80)]  # fmt: skip
    assert place_box(demo, (200, 100), ANCHOR, ring, clear_mm=10, sight=ring) is None
    assert place_box(demo, (200, 100), ANCHOR, ring, clear_mm=10) is not None
