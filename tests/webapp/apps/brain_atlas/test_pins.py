"""Brain atlas pins: a pin marks a point of its region that the wall's picture shows.

Checked against the real template and atlas (small enough to load once per module),
with a ray caster and a label lookup written here that know nothing of ``pins.py``'s
chunks, empty-space skipping or embedded label grid, and on a synthetic volume whose
answers are known exactly.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from typing import Any

import nibabel
import numpy as np
import numpy.typing as npt
import pytest

from wall_client.config import load_wall, parse_wall
from wall_client.layout import apply_affine
from webapp.apps.brain_atlas import pins as pins_module
from webapp.apps.brain_atlas.content import ATLAS_DIR, ContentError, Region
from webapp.apps.brain_atlas.pins import (
    LABELS_FILE,
    LOOKAHEAD,
    LOOKAHEAD_STEP,
    MIN_AREA,
    SEEN,
    TEMPLATE_FILE,
    AtlasVolumes,
    Orientation,
    PinCache,
    PlanePin,
    picture,
    plane_point,
    scene_pins,
    visible_regions,
)
from webapp.apps.brain_atlas.views import ViewPreset
from webapp.core.settings import CONTENT_DIR
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.render import Camera, Footprint, clip_box, scene_to_plane, slice_depth
from webapp.volume.store import VolumeMeta
from webapp.volume.transfer import lookup_table

Array = npt.NDArray[Any]
ATLAS_SHIFT = (25, 27, 0)  # template voxel = atlas voxel + this (PROVENANCE.md)
RIGHT_HEMISPHERE = range(42, 83)


@pytest.fixture(scope="module")
def template() -> Array:
    return np.asarray(nibabel.load(ATLAS_DIR / TEMPLATE_FILE).dataobj).astype(np.float64)


@pytest.fixture(scope="module")
def atlas() -> Array:
    return np.asarray(nibabel.load(ATLAS_DIR / LABELS_FILE).dataobj)


@pytest.fixture(scope="module")
def cache() -> PinCache:
    return PinCache()


def orientation(preset: ViewPreset) -> Orientation:
    return Orientation.of(preset.view, preset.layer())


def atlas_label(atlas: Array, point: Array) -> int:
    """The label at a world point (template mm), read from the atlas file itself."""
    i, j, k = (math.floor(float(c)) - s for c, s in zip(point, ATLAS_SHIFT, strict=True))
    if not (0 <= i < atlas.shape[0] and 0 <= j < atlas.shape[1] and 0 <= k < atlas.shape[2]):
        return 0
    return int(atlas[i, j, k])


def trilinear(values: Array, points: Array) -> Array:
    """Trilinear samples at world points, voxel centres at (i + 0.5) mm, clamped at the
    volume's faces."""
    shape = np.array(values.shape)
    grid = np.clip(points - 0.5, 0, shape - 1)
    base = np.minimum(np.floor(grid).astype(int), shape - 2)
    frac = grid - base
    total = np.zeros(len(points))
    for corner in itertools.product((0, 1), repeat=3):
        weight = np.ones(len(points))
        for axis, c in enumerate(corner):
            weight *= frac[:, axis] if c else 1 - frac[:, axis]
        i, j, k = (base + np.array(corner)).T
        total += weight * values[i, j, k]
    return total


def cast_one_ray(
    template: Array,
    atlas: Array,
    layer: VolumeLayer,
    camera: Camera,
    low: Array,
    high: Array,
    u: float,
    v: float,
) -> tuple[int, float] | None:
    """The label the picture shows at (u, v) and its depth: samples every mm from the
    plane (depth k mm for every whole k, as the renderer), those in the clip box, front
    to back, composited until the opacity reaches SEEN; on a voxel without a label the
    first label up to LOOKAHEAD mm further. None: the ray never gets that opaque."""
    table = lookup_table(layer.transfer)
    start = camera.centre + u * camera.right + v * camera.down
    ks = np.arange(-400, 401)
    points = start + ks[:, None] * camera.forward
    inside = np.all((points >= low) & (points < high), axis=1)
    ks, points = ks[inside], points[inside]
    indices = np.clip(np.rint(trilinear(template, points)), 0, 255).astype(int)  # 0..255
    opacity = 0.0
    for k, point, index in zip(ks, points, indices, strict=True):
        opacity += (1 - opacity) * float(table[index, 3])
        if opacity >= SEEN:
            label, depth = atlas_label(atlas, point), float(k)
            for n in range(1, round(LOOKAHEAD / LOOKAHEAD_STEP) + 1):
                if label:
                    break
                further = start + (k + n * LOOKAHEAD_STEP) * camera.forward
                if np.all((further >= low) & (further < high)):
                    label, depth = atlas_label(atlas, further), k + n * LOOKAHEAD_STEP
            return label, depth
    return None


# --- the volumes ------------------------------------------------------------------


def test_the_labels_sit_on_the_template_grid_shifted_as_the_atlas_says(
    volumes: AtlasVolumes, atlas: Array, template: Array
) -> None:
    assert volumes.labels.shape == template.shape
    i, j, k = ATLAS_SHIFT
    a, b, c = atlas.shape
    assert np.array_equal(volumes.labels[i : i + a, j : j + b, k : k + c], atlas)
    assert volumes.labels.sum(dtype=np.int64) == atlas.sum(dtype=np.int64)  # nothing else
    assert volumes.meta.shape == template.shape
    assert volumes.meta.value_range == (0.0, 255.0)
    assert volumes.meta.extent == (197.0, 233.0, 189.0)


def test_a_store_built_from_another_file_is_refused(volumes: AtlasVolumes) -> None:
    other = volumes.meta.model_copy(update={"name": "other", "shape": (10, 10, 10)})
    with pytest.raises(ContentError, match="not built from"):
        AtlasVolumes.load(meta=other)
    assert AtlasVolumes.load(meta=volumes.meta).meta == volumes.meta


def test_missing_volumes_are_a_content_error(tmp_path: Any) -> None:
    with pytest.raises(ContentError, match=f"{TEMPLATE_FILE}: missing"):
        AtlasVolumes.load(tmp_path)


# --- pins on the real presets ------------------------------------------------------


def test_every_pin_point_lies_in_its_region(
    volumes: AtlasVolumes,
    regions: list[Region],
    presets: list[ViewPreset],
    atlas: Array,
    cache: PinCache,
) -> None:
    by_id = {r.id: r for r in regions}
    checked = 0
    for preset in presets:
        found = cache.get(volumes, regions, preset.view, preset.layer())
        camera = Camera.looking(volumes.meta, preset.view.yaw, preset.view.pitch)
        low, high = clip_box(preset.layer(), volumes.meta)
        for region_id, pin in found.items():
            point = plane_point(camera, pin.u, pin.v, pin.depth)
            assert atlas_label(atlas, point) in by_id[region_id].labels, (preset.id, region_id)
            assert np.all((point >= low) & (point < high)), (preset.id, region_id)
            assert pin.area >= MIN_AREA
            checked += 1
    assert checked > 50


def test_a_composite_pin_is_where_its_ray_shows_the_region(
    volumes: AtlasVolumes,
    regions: list[Region],
    presets: list[ViewPreset],
    template: Array,
    atlas: Array,
    cache: PinCache,
) -> None:
    by_id = {r.id: r for r in regions}
    composite = [p for p in presets if p.layer().mode == "composite"]
    assert composite
    for preset in composite:
        layer = preset.layer()
        camera = Camera.looking(volumes.meta, preset.view.yaw, preset.view.pitch)
        low, high = clip_box(layer, volumes.meta)
        for region_id, pin in cache.get(volumes, regions, preset.view, layer).items():
            seen = cast_one_ray(template, atlas, layer, camera, low, high, pin.u, pin.v)
            assert seen is not None, (preset.id, region_id)
            label, depth = seen
            assert label in by_id[region_id].labels, (preset.id, region_id, label)
            assert depth == pytest.approx(pin.depth), (preset.id, region_id)


def test_the_picture_labels_what_single_rays_show(
    volumes: AtlasVolumes, template: Array, atlas: Array
) -> None:
    """Whole pictures, not just pins: rays at random pixels of an oblique composite
    view and of a mip view agree with the reference caster."""
    rng = np.random.default_rng(5)
    for view, layer in [
        (View(yaw=35, pitch=20), VolumeLayer(volume="mni152", transfer="grey")),
        (
            View(yaw=-120, pitch=-30),
            VolumeLayer(volume="mni152", mode="mip", transfer="hot", clip=CLIP_SOME),
        ),
    ]:
        shown = picture(volumes, Orientation.of(view, layer))
        low, high = clip_box(layer, volumes.meta)
        rows, columns = shown.labels.shape
        for row, column in zip(
            rng.integers(0, rows, 60), rng.integers(0, columns, 60), strict=True
        ):
            seen = cast_one_ray(
                template, atlas, layer, shown.camera, low, high, shown.us[column], shown.vs[row]
            )
            label = 0 if seen is None else seen[0]
            assert shown.labels[row, column] == label, (view, row, column)


CLIP_SOME = ((0.1, 0.8), (0.2, 0.9), (0.15, 0.7))


def test_slice_pins_lie_on_the_slice_plane(
    volumes: AtlasVolumes, regions: list[Region], presets: list[ViewPreset], cache: PinCache
) -> None:
    slices = [p for p in presets if p.layer().mode == "slice"]
    assert slices
    for preset in slices:
        layer = preset.layer()
        camera = Camera.looking(volumes.meta, preset.view.yaw, preset.view.pitch)
        plane = slice_depth(layer, volumes.meta)
        for pin in cache.get(volumes, regions, preset.view, layer).values():
            point = plane_point(camera, pin.u, pin.v, pin.depth)
            assert pin.depth == pytest.approx(plane)
            assert (point - camera.centre) @ camera.forward == pytest.approx(plane)


def test_the_medial_preset_shows_no_right_hemisphere_labels(
    volumes: AtlasVolumes, presets: list[ViewPreset]
) -> None:
    medial = next(p for p in presets if p.id == "left-medial")
    layer = medial.layer()
    assert layer.clip[0][1] <= 0.5  # the right half is clipped away
    shown = picture(volumes, orientation(medial))
    seen = set(np.unique(shown.labels).tolist())
    assert not seen & set(RIGHT_HEMISPHERE)
    assert {24, 20, 35} <= seen  # precuneus, pericalcarine, thalamus
    # without the clip the same view looks at the right hemisphere's lateral side
    whole = layer.model_copy(update={"clip": ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))})
    unclipped = picture(volumes, Orientation.of(medial.view, whole))
    right = np.isin(unclipped.labels, RIGHT_HEMISPHERE).sum()
    left = np.isin(unclipped.labels, range(1, 42)).sum()
    assert right > 50 * max(left, 1)  # the left hemisphere hides behind it


def test_the_lateral_preset_looks_at_the_left_hemisphere(
    volumes: AtlasVolumes, presets: list[ViewPreset]
) -> None:
    lateral = next(p for p in presets if p.id == "left-side")
    labels = picture(volumes, orientation(lateral)).labels
    assert {23, 21, 29} <= set(np.unique(labels).tolist())  # pre-, postcentral, STG
    right = np.isin(labels, RIGHT_HEMISPHERE).sum()
    assert right < 0.01 * np.isin(labels, range(1, 42)).sum()  # a rim at the far edges


# --- the synthetic volume: answers known exactly ---------------------------------


def synthetic() -> AtlasVolumes:
    """A 40 mm cube of background holding a bright block (x, y, z from 10 to 30 mm);
    labels on its face towards -x: region 5 (9 x 5 mm, on the face), region 7 (9 x 5
    mm, 2 mm under the face), region 9 (5 mm under it), region 11 (4 x 4 mm)."""
    template = np.zeros((40, 40, 40), dtype=np.uint8)
    template[10:30, 10:30, 10:30] = 255
    labels = np.zeros_like(template)
    labels[10:12, 15:24, 15:20] = 5
    labels[13, 15:24, 22:27] = 7
    labels[16, 15:24, 10:14] = 9
    labels[10:12, 25:29, 25:29] = 11
    meta = VolumeMeta(
        name="cube",
        source="cube.npy",
        shape=(40, 40, 40),
        spacing=(1.0, 1.0, 1.0),
        brick=8,
        levels=3,
        grid=(5, 5, 5),
        depth=3,
        dtype="int16",
        value_range=(0.0, 255.0),
        background=0,
        fallback_level=0,
        stored_bricks=0,
        empty_bricks=0,
    )
    return AtlasVolumes(template, labels, meta)


def region(region_id: str, *labels: int) -> Region:
    return Region(
        id=region_id, name=region_id, hemisphere="both", labels=list(labels), sets=["full"]
    )


def test_synthetic_pins_sit_at_the_middle_of_what_shows() -> None:
    cube = synthetic()
    found = visible_regions(
        cube,
        [region("face", 5), region("under", 7), region("deep", 9), region("small", 11)],
        Orientation(270.0, 0.0, VolumeLayer(volume="cube", transfer="grey")),
    )
    # looking along +x: u = 20 - y, v = 20 - z; the ray at x = 10 reads half the block
    # (opacity 0.06), at x = 11 the whole (0.5 more): it shows x = 11, depth -9
    assert found["face"] == PlanePin(u=0.5, v=2.5, depth=-9.0, area=45.0)
    # under the face, 2 mm beyond where the ray shows: found by looking further
    assert found["under"] == PlanePin(u=0.5, v=-4.5, depth=-7.0, area=45.0)
    assert "deep" not in found  # 5 mm beyond: not what the viewer sees there
    assert "small" not in found  # 16 mm², below MIN_AREA


def test_a_region_seen_in_two_places_gets_its_pin_in_the_larger() -> None:
    cube = synthetic()
    cube.labels[10:12, 12:15, 12:15] = 5  # a 3 x 3 patch besides the 9 x 5 one
    found = visible_regions(
        cube,
        [region("face", 5)],
        Orientation(270.0, 0.0, VolumeLayer(volume="cube", transfer="grey")),
    )
    pin = found["face"]
    assert (pin.v, pin.depth, pin.area) == (2.5, -9.0, 54.0)
    assert -1.5 <= pin.u <= 2.5  # on the middle line of the 9 x 5 patch (pulled to the 3 x 3)


def test_a_synthetic_slice_reads_the_labels_on_its_plane() -> None:
    cube = synthetic()
    half = math.hypot(40, 40, 40) / 2
    layer = VolumeLayer(volume="cube", mode="slice", slice=-8.5 / half)  # the plane x = 11.5
    found = visible_regions(
        cube, [region("face", 5), region("under", 7)], Orientation(270.0, 0.0, layer)
    )
    assert set(found) == {"face"}
    assert found["face"].u == 0.5 and found["face"].v == 2.5
    assert found["face"].depth == pytest.approx(-8.5)


def test_the_clip_box_hides_what_lies_outside_it() -> None:
    cube = synthetic()
    clipped = VolumeLayer(volume="cube", clip=((0.3, 1.0), (0.0, 1.0), (0.0, 1.0)))  # x >= 12
    found = visible_regions(
        cube, [region("face", 5), region("under", 7)], Orientation(270.0, 0.0, clipped)
    )
    # the cut face at x = 12 shows the block at once: region 7 at x = 13 is 1 mm on
    assert set(found) == {"under"}
    assert found["under"].depth == pytest.approx(-7.0)


# --- plane and scene ----------------------------------------------------------------

WALLS = ["demo", "irregular"]  # a wide stage, and a tall one
VIEWS = [
    View(),
    View(zoom=1.8, center=(0.35, 0.6)),
    View(zoom=0.7, center=(0.55, 0.45), yaw=-90),
]


@pytest.mark.parametrize("wall_id", WALLS)
@pytest.mark.parametrize("view", VIEWS)
def test_pins_go_plane_to_scene_and_back(volumes: AtlasVolumes, wall_id: str, view: View) -> None:
    rng = np.random.default_rng(11)
    plane = {
        f"p{n}": PlanePin(u=float(u), v=float(v), depth=0.0, area=30.0)
        for n, (u, v) in enumerate(rng.uniform(-120, 120, (40, 2)))
    }
    wall = load_wall(CONTENT_DIR / "walls" / f"{wall_id}.toml")
    placed = scene_pins(plane, wall, view, volumes.meta)
    to_plane = scene_to_plane(view, wall.stage, volumes.meta)
    width, height = wall.width, wall.height
    panels = [wall.viewport(d).scene_rect for d in wall.designated()]
    for region_id, pin in plane.items():
        if region_id not in placed:
            # left out only when off the wall or under a designated screen
            to_scene = np.linalg.inv(
                np.array([[to_plane[0], to_plane[2]], [to_plane[1], to_plane[3]]])
            ) @ (np.array([pin.u, pin.v]) - np.array(to_plane[4:]))
            x, y = to_scene
            assert not (0 <= x <= width and 0 <= y <= height) or any(
                panel.contains((x, y)) for panel in panels
            )
            continue
        x, y = placed[region_id]
        assert 0 <= x <= width and 0 <= y <= height
        assert not any(panel.contains((x, y)) for panel in panels)
        assert apply_affine(to_plane, x, y) == pytest.approx((pin.u, pin.v))
    assert placed  # some always land


def test_a_scene_pin_is_where_the_tile_draws_its_plane_point(volumes: AtlasVolumes) -> None:
    """The pin's scene point and a tile's pixel for it agree: both go through the one
    scene -> plane map (the footprint maps the tile's pixels through it)."""
    wall = parse_wall(
        {
            "id": "t",
            "name": "t",
            "bezel_mode": "overlay",
            "grid": {
                "columns": 2,
                "rows": 1,
                "resolution": [400, 300],
                "active_mm": [400, 300],
                "bezel_mm": 0,
            },
        }
    )
    view = View(zoom=1.4, center=(0.45, 0.55), yaw=-90)
    pin = PlanePin(u=-31.0, v=12.5, depth=0.0, area=30.0)
    x, y = scene_pins({"r": pin}, wall, view, volumes.meta)["r"]
    display = next(d for d in wall.displays if d.rect.x <= x < d.rect.x + d.rect.width)
    viewport = wall.viewport(display.id)
    footprint = Footprint.of(viewport, view, wall.stage, volumes.meta)
    px, py = apply_affine(viewport.to_pixels, x, y)
    assert apply_affine(footprint.to_plane, px, py) == pytest.approx((pin.u, pin.v))


# --- orientations and the cache -----------------------------------------------------


def test_zoom_centre_and_volume_name_do_not_change_the_orientation() -> None:
    layer = VolumeLayer(volume="mni152", transfer="tissue")
    a = Orientation.of(View(yaw=-90, pitch=10), layer)
    b = Orientation.of(
        View(yaw=270, pitch=10, zoom=3, center=(0.2, 0.7)),
        layer.model_copy(update={"volume": "other", "slice": 0.4}),  # slice unused here
    )
    assert a == b and hash(a) == hash(b)
    assert a != Orientation.of(View(yaw=-90, pitch=10), layer.model_copy(update={"mode": "mip"}))
    sliced = layer.model_copy(update={"mode": "slice"})
    assert Orientation.of(View(), sliced) != Orientation.of(
        View(), sliced.model_copy(update={"slice": 0.1})
    )


def test_a_cache_hit_returns_the_same_object(
    volumes: AtlasVolumes, regions: list[Region], presets: list[ViewPreset]
) -> None:
    cache = PinCache()
    preset = presets[0]
    first = cache.get(volumes, regions, preset.view, preset.layer())
    moved = preset.view.model_copy(update={"zoom": 2.5, "center": (0.3, 0.4)})
    assert cache.get(volumes, regions, moved, preset.layer("elsewhere")) is first
    assert cache.get(volumes, regions[:3], preset.view, preset.layer()) is not first
    with pytest.raises(TypeError):
        first["x"] = first[next(iter(first))]  # type: ignore[index]


def test_the_cache_is_bounded(volumes: AtlasVolumes) -> None:
    cache = PinCache(size=2)
    few = [region("thalamus", 35)]
    layer = VolumeLayer(volume="mni152", mode="slice")
    results = [cache.get(volumes, few, View(yaw=yaw), layer) for yaw in (0, 10, 20)]
    assert len(cache) == 2
    assert cache.get(volumes, few, View(yaw=20), layer) is results[2]
    assert cache.get(volumes, few, View(yaw=0), layer) is not results[0]  # dropped, redone


def test_threads_asking_at_once_share_one_computation(
    volumes: AtlasVolumes, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[Orientation] = []
    real = pins_module.visible_regions

    def slow(
        volumes: AtlasVolumes, regions: list[Region], orientation: Orientation
    ) -> dict[str, PlanePin]:
        calls.append(orientation)
        time.sleep(0.2)
        return real(volumes, regions, orientation)

    monkeypatch.setattr(pins_module, "visible_regions", slow)
    cache = PinCache()
    few = [region("thalamus", 35)]
    layer = VolumeLayer(volume="mni152", mode="slice")
    results: list[object] = []

    def ask() -> None:
        results.append(cache.get(volumes, few, View(yaw=5), layer))

    threads = [threading.Thread(target=ask) for _ in range(6)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(calls) == 1
    assert len(results) == 6 and all(r is results[0] for r in results)


def test_an_error_is_not_cached(volumes: AtlasVolumes, monkeypatch: pytest.MonkeyPatch) -> None:
    real = pins_module.visible_regions
    failures = [RuntimeError("once")]

    def flaky(
        volumes: AtlasVolumes, regions: list[Region], orientation: Orientation
    ) -> dict[str, PlanePin]:
        if failures:
            raise failures.pop()
        return real(volumes, regions, orientation)

    monkeypatch.setattr(pins_module, "visible_regions", flaky)
    cache = PinCache()
    few = [region("thalamus", 35)]
    layer = VolumeLayer(volume="mni152", mode="slice")
    with pytest.raises(RuntimeError):
        cache.get(volumes, few, View(), layer)
    assert "thalamus" in cache.get(volumes, few, View(), layer)
