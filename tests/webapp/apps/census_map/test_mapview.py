"""The map on the wall: projection, which tracts carry codes, each tile's share."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Polygon

from tag_service.placement import Layout, marks_of, pin_conflicts
from tests.webapp.apps.census_map.conftest import grid_dataset, sacramento
from tests.webapp.apps.shipped_layouts import census_codes, census_layout, shipped_walls
from wall_client.config import load_walls
from wall_client.layout import Rect, Wall
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.mapview import (
    COLOURS,
    MARGIN,
    MAX_CLUSTER_TRACTS,
    SIMPLIFY_PX,
    MapGeometry,
    code_anchors,
    label_mm,
    projection,
    shown_area,
    tile_view,
    tract_codes,
)
from webapp.choropleth.palettes import contrast_ratio
from webapp.core.settings import CONTENT_DIR
from webapp.engine.wall_state import View


@pytest.fixture(scope="module")
def walls() -> dict[str, Wall]:
    loaded = load_walls([CONTENT_DIR / "walls"])
    # the demo wall with every display showing the map (no panels)
    open_wall = dataclasses.replace(loaded["demo"], id="open", screens={}, stage_ids=())
    return {**loaded, "open": open_wall}


def scene_extent(geometry: MapGeometry, wall: Wall, view: View) -> tuple[float, ...]:
    project = projection(geometry, wall, view)
    minx, miny, maxx, maxy = geometry.extent
    return (*project.point(minx, miny), *project.point(maxx, maxy))


SHIPPED_WALLS = ("demo", "hiperwall", "irregular", "kl-3x3")


def scene_land(geometry: MapGeometry, wall: Wall, view: View) -> shapely.Geometry:
    """Every tract, as drawn on the wall (scene mm)."""
    project = projection(geometry, wall, view)
    return shapely.transform(
        shapely.union_all(geometry.shapes), lambda c: c * project.scale + (project.dx, project.dy)
    )


def covered(land: shapely.Geometry, wall: Wall, share: float) -> set[str]:
    """The displays ``land`` covers at least ``share`` of."""
    return {
        d.id
        for d in wall.displays
        if land.intersection(shapely.box(*rect_bounds(wall.viewport(d.id).scene_rect))).area
        >= share * d.rect.width * d.rect.height
    }


def rect_bounds(rect: Rect) -> tuple[float, float, float, float]:
    return (rect.x, rect.y, rect.right, rect.bottom)


def stage_scale(geometry: MapGeometry, wall: Wall) -> float:
    """The scale of the rule before the fit: the data's bounding box in the stage, 3 %
    of it kept free on every side."""
    minx, miny, maxx, maxy = geometry.extent
    stage = wall.stage
    return min(stage.width * 0.94 / (maxx - minx), stage.height * 0.94 / (maxy - miny))


@pytest.mark.parametrize("name", SHIPPED_WALLS)
def test_at_zoom_one_every_tract_lies_on_the_displays_that_show_the_map(
    walls: dict[str, Wall], shipped: DataSet, name: str
) -> None:
    """No tract reaches a designated screen or the wall's edge (the margin kept), and the
    map is never smaller than the data's bounding box framed in the stage made it."""
    wall = walls[name]
    geometry = MapGeometry.of(shipped)
    land = scene_land(geometry, wall, View())
    margin = MARGIN * min(wall.width, wall.height)
    x0, y0, x1, y1 = land.bounds
    assert margin <= x0 and x1 <= wall.width - margin
    assert margin <= y0 and y1 <= wall.height - margin
    for display in wall.designated():
        panel = shapely.box(*rect_bounds(wall.viewport(display).scene_rect))
        assert land.distance(panel) >= margin * 0.999, display
    assert shown_area(wall).buffer(-margin * 0.999).covers(land)
    assert projection(geometry, wall, View()).scale >= stage_scale(geometry, wall)


def test_the_map_takes_the_room_its_shape_allows_not_its_bounding_box(
    walls: dict[str, Wall],
) -> None:
    """The demo wall with only its top-right display designated leaves an L of five
    displays; tracts laid out as an L (five across below, three above) take both rows,
    their bounding box reaching over the designated display where no tract does (the
    stage, the largest free block, holds only two columns)."""
    wall = dataclasses.replace(walls["demo"], id="corner", screens={"public": ("r1c3",)})
    squares = grid_dataset(columns=5, rows=2)
    tracts = tuple(t for i, t in enumerate(squares.tracts) if i not in (3, 4))
    data = dataclasses.replace(squares, tracts=tracts)
    geometry = MapGeometry.of(data)
    land = scene_land(geometry, wall, View())
    margin = MARGIN * min(wall.width, wall.height)
    assert land.bounds[3] - land.bounds[1] > 0.9 * (wall.height - 2 * margin)
    public = shapely.box(*rect_bounds(wall.viewport("r1c3").scene_rect))
    assert not land.intersects(public)
    assert shapely.box(*land.bounds).intersects(public)
    assert projection(geometry, wall, View()).scale > 1.5 * stage_scale(geometry, wall)


def test_the_map_shows_on_free_displays_and_the_bezels_between_them(
    walls: dict[str, Wall],
) -> None:
    wall = walls["hiperwall"]
    area = shown_area(wall)
    rect = {d.id: wall.viewport(d.id).scene_rect for d in wall.displays}
    assert area.covers(shapely.Point(rect["r2c2"].right + 1, rect["r2c2"].center[1]))
    assert area.covers(shapely.Point(rect["r2c2"].right + 1, rect["r2c2"].bottom + 1))
    assert not area.covers(shapely.Point(rect["r1c4"].right + 1, rect["r1c4"].center[1]))
    assert not area.covers(shapely.Point(rect["r5c5"].center[0], rect["r5c5"].bottom + 1))
    assert not area.intersects(shapely.box(*rect_bounds(rect["r1c5"])))
    assert area.covers(shapely.box(*rect_bounds(rect["r3c1"])))


def test_on_hiperwall_the_map_covers_more_displays_than_its_bounding_box_in_the_stage(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    """The shipped data's shape (its north-east high, its south-west low) meets the
    wall's free area (the public and menu screens top right, registration bottom left)
    badly, so the fit gains little there; still it covers more displays than before."""
    wall = walls["hiperwall"]
    geometry = MapGeometry.of(shipped)
    fitted = covered(scene_land(geometry, wall, View()), wall, 0.1)
    minx, miny, maxx, maxy = geometry.extent
    scale = stage_scale(geometry, wall)
    cx, cy = wall.stage.center
    before = shapely.transform(
        shapely.union_all(geometry.shapes),
        lambda c: (c - ((minx + maxx) / 2, (miny + maxy) / 2)) * scale + (cx, cy),
    )
    assert len(fitted) > len(covered(before, wall, 0.1))
    assert fitted.isdisjoint(wall.designated())


def test_the_fit_is_made_once_per_wall_and_the_same_every_time(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    geometry = MapGeometry.of(shipped)
    fitted = geometry.fit(walls["hiperwall"])
    assert geometry.fit(walls["hiperwall"]) is fitted
    assert MapGeometry.of(shipped).fit(walls["hiperwall"]) == fitted
    assert geometry.fit(walls["demo"]) != fitted


def test_pan_and_zoom_move_the_map_like_every_scene_layer(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    """On hiperwall the map stands left of the stage's middle; zooming in keeps it there."""
    wall = walls["hiperwall"]
    geometry = MapGeometry.of(shipped)
    base = projection(geometry, wall, View())
    panned = projection(geometry, wall, View(center=(0.6, 0.5)))
    zoomed = projection(geometry, wall, View(zoom=2))
    u, v = geometry.label_points[0]
    assert panned.point(u, v)[0] == pytest.approx(base.point(u, v)[0] - 0.1 * wall.stage.width)
    # zooming about where the map's middle stands at zoom 1 doubles every distance from it
    minx, miny, maxx, maxy = geometry.extent
    cx, cy = base.point((minx + maxx) / 2, (miny + maxy) / 2)
    bx, by = base.point(u, v)
    zx, zy = zoomed.point(u, v)
    assert (zx - cx, zy - cy) == pytest.approx((2 * (bx - cx), 2 * (by - cy)))


def test_a_tract_carries_a_code_only_when_the_code_fits_inside_it(
    walls: dict[str, Wall],
) -> None:
    wall = walls["open"]
    data = grid_dataset()
    geometry = MapGeometry.of(data)
    project = projection(geometry, wall, View())
    room_mm = float(geometry.room.min()) * project.scale  # the squares are all alike
    assert len(code_anchors(geometry, wall, View(), 2 * room_mm * 0.99)) == len(data.tracts)
    assert code_anchors(geometry, wall, View(), 2 * room_mm * 1.01) == {}
    # zooming in makes room: twice the zoom, twice the code (for the tracts still on the wall)
    on_wall = code_anchors(geometry, wall, View(zoom=2), 1.0)
    assert 0 < len(on_wall) < len(data.tracts)
    assert code_anchors(geometry, wall, View(zoom=2), 2 * room_mm * 1.98) == on_wall


def test_codes_stand_at_the_tract_centre_and_only_on_the_wall(walls: dict[str, Wall]) -> None:
    wall = walls["open"]
    data = grid_dataset()
    geometry = MapGeometry.of(data)
    anchors = code_anchors(geometry, wall, View(), 1.0)
    project = projection(geometry, wall, View())
    for tract in data.tracts:
        centre = shapely.transform(tract.shape.centroid, lambda c: c)  # lon/lat
        u = centre.x * math.cos(math.radians(float(np.mean(geometry.extent[1::2]) * -1)))
        assert tract.geoid in anchors
        x, _ = anchors[tract.geoid]
        assert x == pytest.approx(project.point(u, -centre.y)[0], abs=1.0)
    # panned so the map's middle is on the wall's right edge: half the tracts are off it
    centred = code_anchors(geometry, wall, View(zoom=2), 1.0)
    panned = code_anchors(geometry, wall, View(center=(0.25, 0.5), zoom=2), 1.0)
    assert len(panned) == len(centred) // 2 > 0
    assert all(x <= wall.width for x, _ in panned.values())


def test_tiles_share_the_map_without_losing_a_tract(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    wall = walls["demo"]
    geometry = MapGeometry.of(shipped)
    seen: set[str] = set()
    for display in wall.displays:
        view = tile_view(shipped, geometry, wall, display.id, View(), {})
        width, height = display.resolution
        reach_px = 8 * label_mm(wall) * width / display.rect.width + 2
        for tract in view["tracts"]:
            seen.add(tract["id"])
            points = np.concatenate([np.reshape(ring, (-1, 2)) for ring in tract["rings"]])
            assert points[:, 0].min() >= -reach_px and points[:, 0].max() <= width + reach_px
            assert points[:, 1].min() >= -reach_px and points[:, 1].max() <= height + reach_px
            assert tract["group"] == shipped.group_of[tract["id"]]
    assert seen == {t.geoid for t in shipped.tracts}


def test_codes_and_groups_travel_with_the_tracts(walls: dict[str, Wall]) -> None:
    wall = walls["demo"]
    data = grid_dataset()
    geometry = MapGeometry.of(data)
    codes = {data.tracts[0].geoid: "ABC1234"}
    views = [tile_view(data, geometry, wall, d.id, View(), codes) for d in wall.displays]
    coded = [t for v in views for t in v["tracts"] if t["code"]]
    assert coded and {t["code"] for t in coded} == {"ABC1234"}


def test_outlines_stay_within_half_a_pixel(walls: dict[str, Wall], shipped: DataSet) -> None:
    wall = walls["demo"]
    geometry = MapGeometry.of(shipped)
    display = wall.displays[1]
    project = projection(geometry, wall, View())
    px_per_mm = display.resolution[0] / display.rect.width
    tolerance = SIMPLIFY_PX / px_per_mm / project.scale
    simplified = geometry.outlines(tolerance)
    error_px = shapely.hausdorff_distance(simplified, geometry.shapes) * project.scale * px_per_mm
    assert float(np.max(error_px)) <= 0.5
    assert (
        shapely.get_num_coordinates(simplified).sum()
        < 0.6 * shapely.get_num_coordinates(geometry.shapes).sum()
    )


def test_label_room_is_a_circle_inside_the_tract(shipped: DataSet) -> None:
    geometry = MapGeometry.of(shipped)
    for index in range(0, len(shipped.tracts), 37):
        point = shapely.Point(*geometry.label_points[index])
        shape = geometry.shapes[index]
        assert shape.contains(point)
        circle = point.buffer(float(geometry.room[index]) * 0.99)
        assert shape.contains(circle) or isinstance(shape, Polygon) is False


def test_no_code_stands_on_a_panel_or_on_another_code(walls: dict[str, Wall]) -> None:
    wall = walls["demo"]
    data = grid_dataset(columns=12, rows=6, size=0.004)
    geometry = MapGeometry.of(data)
    panels = [
        wall.viewport(d.id).scene_rect
        for ids in wall.screens.values()
        for d in map(wall.display, ids)
    ]
    side = 150.0
    zoomed = View(zoom=2.5)  # the map reaches beyond the stage, under the panels
    anchors = code_anchors(geometry, wall, zoomed, side)
    assert anchors
    for x, y in anchors.values():
        assert not any(r.x <= x < r.right and r.y <= y < r.bottom for r in panels)
    points = list(anchors.values())
    for i, (x, y) in enumerate(points):
        for ox, oy in points[i + 1 :]:
            assert abs(x - ox) >= side or abs(y - oy) >= side
    everywhere = code_anchors(geometry, walls["open"], View(), 1.0)
    assert len(everywhere) == len(data.tracts) > len(anchors)


# --- own codes and cluster codes ---------------------------------------------------------


FOOTPRINT = (156.0, 177.0)  # a 104 mm walk-up code with its caption and gap, on the demo


def test_every_tract_on_the_map_gets_its_own_code_or_a_cluster_code(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    wall = walls["demo"]
    geometry = MapGeometry.of(shipped)
    codes = tract_codes(geometry, wall, View(), 104.0, FOOTPRINT)
    clustered = [g for cluster in codes.clusters for g in cluster.geoids]
    assert len(clustered) == len(set(clustered)), "a tract is in one cluster at most"
    assert set(clustered).isdisjoint(codes.own)
    assert len(clustered) + len(codes.own) == len(shipped.tracts) == 403
    assert all(2 <= len(c.geoids) <= MAX_CLUSTER_TRACTS for c in codes.clusters)
    for cluster in codes.clusters:  # a cluster's code wants the middle of its tracts
        project = projection(geometry, wall, View())
        points = [
            project.point(*geometry.label_points[geometry.geoids.index(g)]) for g in cluster.geoids
        ]
        assert cluster.anchor == pytest.approx(tuple(np.mean(points, axis=0)))


def test_panning_keeps_the_clusters_and_zooming_in_gives_more_tracts_their_own_code(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    wall = walls["open"]
    geometry = MapGeometry.of(shipped)
    centred = tract_codes(geometry, wall, View(zoom=1.5), 104.0, FOOTPRINT)
    panned = tract_codes(geometry, wall, View(zoom=1.5, center=(0.52, 0.5)), 104.0, FOOTPRINT)
    assert {c.geoids for c in centred.clusters} == {c.geoids for c in panned.clusters}
    closer = tract_codes(geometry, wall, View(zoom=4), 104.0, FOOTPRINT)
    assert len(closer.own) > len(centred.own)


def test_the_tracts_of_a_code_without_a_spot_join_the_nearest_placed_cluster(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    codes = tract_codes(MapGeometry.of(shipped), walls["demo"], View(), 104.0, FOOTPRINT)
    keys = [key for key, _ in codes.anchors()]
    lost = [key for key in keys if key.startswith("cluster:")][:2]
    lost_own = next(key for key in keys if key.startswith("tract:"))
    kept = codes.keeping(set(keys) - {*lost, lost_own})
    assert len(kept.clusters) == len(codes.clusters) - 2
    assert lost_own.removeprefix("tract:") not in kept.own
    reached = set(kept.own) | {g for c in kept.clusters for g in c.geoids}
    assert len(reached) == 403, "nobody is lost"
    assert {c.anchor for c in kept.clusters} <= {c.anchor for c in codes.clusters}


def test_tract_outlines_stand_out_from_the_fills_they_separate() -> None:
    """WCAG non-text contrast (3:1) between an outline and what lies on either side of
    it: a tract's fill, or the background beyond the map (and under hidden groups)."""
    assert contrast_ratio(COLOURS["outline"], COLOURS["fill"]) >= 3
    assert contrast_ratio(COLOURS["outline"], COLOURS["background"]) >= 3
    assert contrast_ratio(COLOURS["label"], COLOURS["fill"]) >= 4.5, "labels are text"


def test_outlines_are_as_wide_as_read_from_the_seats(
    walls: dict[str, Wall], shipped: DataSet
) -> None:
    """About 2.6 arcminutes at the seat distance: wider in pixels where pixels are small
    or people sit far, never a hairline."""
    geometry = MapGeometry.of(shipped)
    widths = {}
    for name in ("demo", "kl-3x3"):
        wall = walls[name]
        display = wall.displays[0]
        view = tile_view(shipped, geometry, wall, display.id, View(), {})
        mm = view["outline_px"] * display.rect.width / display.resolution[0]
        arcmin = math.degrees(mm / 1000 / wall.seat_distance_m) * 60
        assert arcmin == pytest.approx(2.6, abs=0.1)
        assert view["colours"] == COLOURS
        widths[name] = view["outline_px"]
    assert min(widths.values()) >= 2
    far = dataclasses.replace(walls["demo"], seat_distance_m=2 * walls["demo"].seat_distance_m)
    view = tile_view(shipped, geometry, far, "r2c2", View(), {})
    assert view["outline_px"] == pytest.approx(2 * widths["demo"], abs=0.1)


# --- pins on the shipped walls --------------------------------------------------------

CENSUS_VIEWS = {"whole": View(), "zoom 3": View(center=(0.5, 0.5), zoom=3.0)}


@pytest.fixture(scope="module")
def census_layouts() -> dict[tuple[str, str], Layout]:
    """The census map's layout on every shipped wall at the whole view, and zoomed in on
    the demo wall, computed once for the tests that read them."""
    dataset = sacramento()
    geometry = MapGeometry.of(dataset)
    layouts = {}
    for name, wall in sorted(shipped_walls().items()):
        for view_name, view in CENSUS_VIEWS.items():
            if view_name != "whole" and name != "demo":
                continue
            codes = census_codes(dataset, geometry, wall, view)
            layouts[name, view_name] = census_layout(dataset, wall, codes)
    return layouts


def test_no_census_pin_crosses_another_or_hides_under_a_code(
    census_layouts: dict[tuple[str, str], Layout],
) -> None:
    """Issue 31: at the whole view, cluster codes stood on a neighbour's pin head (4 on
    the demo wall, 6 on HIPerWall) and pins ran under codes."""
    assert {wall for wall, _ in census_layouts} == set(shipped_walls())
    for (wall, view), layout in census_layouts.items():
        conflicts = [str(c) for c in pin_conflicts(marks_of(layout))]
        assert not conflicts, f"{wall} at {view}: {conflicts}"


def test_every_tract_and_cluster_code_the_map_declares_finds_its_spot(
    census_layouts: dict[tuple[str, str], Layout],
) -> None:
    """The app tries its codes before declaring them, so the wall places every one."""
    for (wall, view), layout in census_layouts.items():
        lost = [u for u in layout.unplaced if u.key.startswith(("tract:", "cluster:"))]
        assert not lost, f"{wall} at {view}: {lost}"
        assert sum(p.key.startswith(("tract:", "cluster:")) for p in layout.placed) > 10
