"""Rendering a tile, checked against a brute-force ray caster written here.

The reference below knows nothing of ``render.py``'s bricks, padding, empty-space
skipping or ray trimming: it samples the whole volume at a level along every ray at
depths ``k * step`` for every integer ``k``, keeps the samples inside the clip box,
interpolates trilinearly (clamping at the volume's faces), looks the colour up and
composites front to back.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from wall_client.config import parse_wall
from wall_client.layout import Wall
from webapp.engine.wall_state import View, VolumeLayer
from webapp.engine.wall_state import VolumeMode as Mode
from webapp.volume.build import build_store, open_source
from webapp.volume.render import (
    Camera,
    Footprint,
    Voxels,
    fallback_plan,
    finest_level,
    plan_tile,
    render,
    useful_level,
    visible_test,
    voxel_size,
)
from webapp.volume.store import VolumeMeta, VolumeStore
from webapp.volume.transfer import lookup_table
from webapp.volume.wavelet import downsample

SHAPE = (40, 36, 28)
BRICK = 8
BIG_BUDGET = 1 << 22  # every tile affords level 0
# a 2x2 wall of small displays, 2 mm a pixel, with 4 mm bezels (the overlay hides
# what lies behind them, so tiles' footprints do not abut)
WALL: dict[str, Any] = {
    "id": "t",
    "name": "t",
    "screens": {"registration": []},  # no panels: the picture is framed on the whole wall
    "bezel_mode": "overlay",
    "grid": {
        "columns": 2,
        "rows": 2,
        "resolution": [48, 32],
        "active_mm": [96, 64],
        "bezel_mm": 4,
    },
}
DISPLAYS = ("r1c1", "r1c2", "r2c1", "r2c2")
VIEWS = [
    View(yaw=0, pitch=0),
    View(yaw=30, pitch=20),
    View(yaw=90, pitch=0),
    View(yaw=-60, pitch=45),
    View(yaw=30, pitch=20, zoom=2),
    View(yaw=-60, pitch=45, zoom=2, center=(0.4, 0.6)),
    View(yaw=0, pitch=0, zoom=1, center=(0.6, 0.45)),
]
# faces off the sample lattice of the axis-aligned views (faces on it: see
# test_a_sample_on_the_clip_box_high_face_is_left_out_whichever_way_the_ray_runs)
CLIP = ((0.13, 0.77), (0.21, 0.88), (0.0, 0.66))
WHOLE = ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))


def blob_volume(shape: tuple[int, int, int] = SHAPE, seed: int = 7) -> npt.NDArray[Any]:
    """A smooth uint8 volume: Gaussian blobs scaled to 0..255 on an empty background."""
    rng = np.random.default_rng(seed)
    grid = np.indices(shape).astype(np.float64)
    volume = np.zeros(shape)
    for _ in range(5):
        centre = rng.uniform(0.25, 0.75, 3) * np.array(shape)
        width = rng.uniform(0.08, 0.2) * min(shape)
        squared = sum((grid[a] - centre[a]) ** 2 for a in range(3))
        volume += rng.uniform(0.5, 1.0) * np.exp(-squared / (2 * width**2))
    volume = volume / volume.max() * 255
    volume[volume < 12] = 0
    blobs: npt.NDArray[Any] = volume.astype(np.uint8)
    return blobs


@pytest.fixture(scope="module")
def source() -> npt.NDArray[Any]:
    return blob_volume()


@pytest.fixture(scope="module")
def store_path(tmp_path_factory: pytest.TempPathFactory, source: npt.NDArray[Any]) -> Path:
    base = tmp_path_factory.mktemp("render")
    np.save(base / "blobs.npy", source)
    source_file = open_source(base / "blobs.npy")
    build_store(source_file, base / "blobs", name="blobs", brick=BRICK, fallback_voxels=3000)
    return base / "blobs"


@pytest.fixture
def store(store_path: Path) -> VolumeStore:
    """The blobs (41 of their 100 bricks are empty), freshly opened: no reads yet."""
    return VolumeStore(store_path)


@pytest.fixture(scope="module")
def shared_store(store_path: Path) -> VolumeStore:
    """The blobs, opened once for the property tests."""
    return VolumeStore(store_path)


@pytest.fixture(scope="module")
def noisy_source(source: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """The blobs over a faint noise (0..3, transparent): no brick is empty."""
    noise = np.random.default_rng(1).integers(0, 4, size=SHAPE).astype(np.uint8)
    noisy: npt.NDArray[Any] = np.maximum(source, noise)
    return noisy


@pytest.fixture(scope="module")
def noisy_store(
    tmp_path_factory: pytest.TempPathFactory, noisy_source: npt.NDArray[Any]
) -> VolumeStore:
    base = tmp_path_factory.mktemp("noisy")
    np.save(base / "noisy.npy", noisy_source)
    build_store(open_source(base / "noisy.npy"), base / "noisy", name="noisy", brick=BRICK)
    store = VolumeStore(base / "noisy")
    assert store.meta.empty_bricks == 0
    return store


@pytest.fixture(scope="module")
def wall() -> Wall:
    return parse_wall(WALL)


# --- the reference ---------------------------------------------------------------


def whole_volume(meta: VolumeMeta, original: npt.NDArray[Any], level: int) -> npt.NDArray[Any]:
    """The whole volume at ``level``: the original voxels, or the brick-padded volume
    downsampled and cropped to the level's shape."""
    if level == 0:
        return original.astype(np.float64)
    padded = np.full(tuple(g * meta.brick for g in meta.grid), meta.background, dtype=np.int64)
    padded[: original.shape[0], : original.shape[1], : original.shape[2]] = original
    x, y, z = meta.level_shape(level)
    return downsample(padded, level)[:x, :y, :z].astype(np.float64)


def trilinear(volume: npt.NDArray[Any], coords: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """Values at continuous voxel coordinates (n, 3), clamped to [0, shape - 1]."""
    shape = np.array(volume.shape)
    clamped = np.clip(coords, 0, shape - 1)
    base = np.minimum(np.floor(clamped).astype(np.int64), np.maximum(shape - 2, 0))
    frac = clamped - base
    after = np.minimum(base + 1, shape - 1)
    total = np.zeros(len(coords))
    for corner in itertools.product((0, 1), repeat=3):
        index = tuple(after[:, a] if corner[a] else base[:, a] for a in range(3))
        weight = np.ones(len(coords))
        for a in range(3):
            weight *= frac[:, a] if corner[a] else 1 - frac[:, a]
        total += weight * volume[index]
    return total


def reference_render(
    volume: npt.NDArray[Any],
    meta: VolumeMeta,
    camera: Camera,
    footprint: Footprint,
    layer: VolumeLayer,
    level: int,
    scale: int,
) -> npt.NDArray[Any]:
    """The tile's image by brute force: ``volume`` is the whole volume at ``level``."""
    w, h = footprint.pixels
    columns, rows = -(-w // scale), -(-h // scale)
    x, y = np.meshgrid((np.arange(columns) + 0.5) * scale, (np.arange(rows) + 0.5) * scale)
    a, b, c, d, e, f = footprint.to_plane
    u = (a * x + c * y + e).ravel()
    v = (b * x + d * y + f).ravel()
    starts = camera.centre + u[:, None] * camera.right + v[:, None] * camera.down
    extent = np.array(meta.extent)
    clip_low = np.array([low for low, _ in layer.clip]) * extent
    clip_high = np.array([high for _, high in layer.clip]) * extent
    voxel = np.array(meta.spacing) * 2**level
    table = lookup_table(layer.transfer).astype(np.float64)
    low, high = meta.value_range

    def sample(points: npt.NDArray[Any]) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        inside = np.all((points >= clip_low) & (points < clip_high), axis=1)
        return inside, trilinear(volume, points / voxel - 0.5)

    def index(value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        return np.clip(np.rint((value - low) * 255 / (high - low)), 0, 255).astype(np.int64)

    if layer.mode == "slice":
        inside, value = sample(starts + layer.slice * math.hypot(*meta.extent) / 2 * camera.forward)
        colour = table[index(value), :3] * inside[:, None]
    else:
        step = min(meta.spacing) * 2**level
        reach = math.ceil(math.hypot(*meta.extent) / 2 / step) + 1  # beyond every corner
        colour = np.zeros((len(starts), 3))
        opacity = np.zeros(len(starts))
        best = np.full(len(starts), -np.inf)
        for k in range(-reach, reach + 1):
            inside, value = sample(starts + k * step * camera.forward)
            if layer.mode == "mip":
                best = np.where(inside, np.maximum(best, value), best)
                continue
            entry = table[index(value)]
            alpha = (1 - (1 - entry[:, 3]) ** step) * inside
            colour += ((1 - opacity) * alpha)[:, None] * entry[:, :3]
            opacity += (1 - opacity) * alpha
        if layer.mode == "mip":
            seen = np.isfinite(best)
            colour = table[index(np.where(seen, best, low)), :3] * seen[:, None]
    image: npt.NDArray[Any] = np.clip(np.rint(colour * 255), 0, 255).astype(np.uint8)
    return image.reshape(rows, columns, 3)


def assert_close(image: npt.NDArray[Any], expected: npt.NDArray[Any]) -> None:
    """At most 2 grey levels apart, and that on at most 0.5% of the pixels; at most 1
    elsewhere. render.py stops a ray once its opacity passes 0.996 (what lies behind
    adds at most 0.004 * 255 ~ 1 level, which rounding can make 2) and interpolates in
    float32 (a value on a lookup entry's boundary may round to the neighbouring entry)."""
    assert image.shape == expected.shape
    difference = np.abs(image.astype(np.int16) - expected.astype(np.int16)).max(axis=2)
    assert difference.max() <= 2, f"{difference.max()} levels apart"
    assert (difference == 2).mean() <= 0.005, f"{(difference == 2).sum()} pixels 2 levels apart"


def tile(store: VolumeStore, wall: Wall, display: str, view: View) -> tuple[Camera, Footprint]:
    meta = store.meta
    camera = Camera.looking(meta, view.yaw, view.pitch)
    footprint = Footprint.of(wall.viewport(display), view, wall.stage, meta)
    return camera, footprint


def compare_wall(
    store: VolumeStore,
    original: npt.NDArray[Any],
    wall: Wall,
    view: View,
    layer: VolumeLayer,
    budget: int,
) -> set[int]:
    """Render every tile of the wall and compare it with the reference at the level
    its plan chose; the levels seen."""
    meta = store.meta
    levels = set()
    lit = 0.0
    for display in DISPLAYS:
        camera, footprint = tile(store, wall, display, view)
        plan = plan_tile(store, camera, footprint, layer, budget)
        image = render(Voxels.of(store, plan), meta, camera, footprint, layer, plan.scale)
        volume = whole_volume(meta, original, plan.level)
        expected = reference_render(volume, meta, camera, footprint, layer, plan.level, plan.scale)
        try:
            assert_close(image, expected)
        except AssertionError as error:
            raise AssertionError(f"{display} at level {plan.level}: {error}") from None
        levels.add(plan.level)
        lit += float((expected.max(axis=2) > 2).mean()) / len(DISPLAYS)
    # the comparison proves little over a black wall
    assert lit > 0.005, f"only {lit:.2%} of the wall shows anything"
    return levels


def view_id(view: View) -> str:
    x, y = view.center
    return f"yaw{view.yaw:g}-pitch{view.pitch:g}-zoom{view.zoom:g}-at{x:g},{y:g}"


# --- the image against the reference -------------------------------------------------


@pytest.mark.parametrize("mode", ["composite", "mip"])
@pytest.mark.parametrize("view", VIEWS, ids=view_id)
def test_every_tile_matches_the_reference(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, view: View, mode: Mode
) -> None:
    layer = VolumeLayer(volume="blobs", mode=mode)
    assert compare_wall(store, source, wall, view, layer, BIG_BUDGET) == {0}


@pytest.mark.parametrize("view", VIEWS, ids=view_id)
def test_every_tile_matches_the_reference_with_a_clip_box_in_mip(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, view: View
) -> None:
    layer = VolumeLayer(volume="blobs", mode="mip", clip=CLIP)
    assert compare_wall(store, source, wall, view, layer, BIG_BUDGET) == {0}


@pytest.mark.parametrize("view", VIEWS, ids=view_id)
def test_every_tile_matches_the_reference_with_a_clip_box_in_composite(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, view: View
) -> None:
    layer = VolumeLayer(volume="blobs", mode="composite", clip=CLIP)
    assert compare_wall(store, source, wall, view, layer, BIG_BUDGET) == {0}


# The coarser levels are compared on a volume whose every brick is stored (and, below,
# beside empty bricks).
COARSE_BUDGETS = [3000, 0]  # 3000: level 1 or 2, depending on the view; 0: level 3


@pytest.mark.parametrize("budget", COARSE_BUDGETS)
@pytest.mark.parametrize("clipped", [False, True], ids=["whole", "clipped"])
@pytest.mark.parametrize("view", VIEWS, ids=view_id)
def test_a_coarser_level_matches_the_reference_at_that_level_in_mip(
    noisy_store: VolumeStore,
    noisy_source: npt.NDArray[Any],
    wall: Wall,
    view: View,
    clipped: bool,
    budget: int,
) -> None:
    layer = VolumeLayer(volume="noisy", mode="mip", clip=CLIP if clipped else WHOLE)
    levels = compare_wall(noisy_store, noisy_source, wall, view, layer, budget)
    assert min(levels) > 0
    assert budget > 0 or levels == {noisy_store.meta.levels}


COARSE_COMPOSITE_CASES = [
    pytest.param(
        view,
        clipped,
        budget,
        id=f"{view_id(view)}-{'clipped' if clipped else 'whole'}-{budget}",
    )
    for view in VIEWS
    for clipped in (False, True)
    for budget in COARSE_BUDGETS
]


@pytest.mark.parametrize(("view", "clipped", "budget"), COARSE_COMPOSITE_CASES)
def test_a_coarser_level_matches_the_reference_at_that_level_in_composite(
    noisy_store: VolumeStore,
    noisy_source: npt.NDArray[Any],
    wall: Wall,
    view: View,
    clipped: bool,
    budget: int,
) -> None:
    layer = VolumeLayer(volume="noisy", clip=CLIP if clipped else WHOLE)
    levels = compare_wall(noisy_store, noisy_source, wall, view, layer, budget)
    assert min(levels) > 0
    assert budget > 0 or levels == {noisy_store.meta.levels}


@pytest.mark.parametrize("view", VIEWS, ids=view_id)
def test_the_coarsest_level_beside_empty_bricks_matches_the_reference_in_mip(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, view: View
) -> None:
    layer = VolumeLayer(volume="blobs", mode="mip")
    assert compare_wall(store, source, wall, view, layer, 0) == {store.meta.levels}


# --- minimal cases of the differences found ------------------------------------------

ONE_DISPLAY: dict[str, Any] = {
    "id": "one",
    "name": "one",
    "screens": {"registration": []},
    "grid": {
        "columns": 1,
        "rows": 1,
        "resolution": [64, 64],
        "active_mm": [128, 128],
        "bezel_mm": 0,
    },
}


def small_store(base: Path, volume: npt.NDArray[Any]) -> VolumeStore:
    np.save(base / "small.npy", volume)
    build_store(open_source(base / "small.npy"), base / "small", name="small", brick=BRICK)
    return VolumeStore(base / "small")


def one_tile(
    store: VolumeStore, volume: npt.NDArray[Any], view: View, layer: VolumeLayer
) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """The only tile of a one-display wall, rendered at level 0 and by the reference."""
    wall = parse_wall(ONE_DISPLAY)
    meta = store.meta
    camera = Camera.looking(meta, view.yaw, view.pitch)
    footprint = Footprint.of(wall.viewport("r1c1"), view, wall.stage, meta)
    plan = plan_tile(store, camera, footprint, layer, BIG_BUDGET)
    assert plan.level == 0
    image = render(Voxels.of(store, plan), meta, camera, footprint, layer, plan.scale)
    expected = reference_render(volume, meta, camera, footprint, layer, 0, plan.scale)
    return image, expected


def test_a_ray_with_a_short_stretch_through_the_box_is_not_dropped(tmp_path: Path) -> None:
    # an opaque cube seen corner on: rays near its silhouette cross it for under 4 mm
    cube = np.full((16, 16, 16), 200, dtype=np.uint8)
    cube[0, 0, 0] = 0  # the background
    store = small_store(tmp_path, cube)
    image, expected = one_tile(store, cube, View(yaw=45, zoom=0.5), VolumeLayer(volume="small"))
    lit, dark = expected.max(axis=2) > 0, image.max(axis=2) == 0
    assert not (lit & dark).any()
    assert_close(image, expected)


def test_samples_beside_the_held_bricks_interpolate_with_them(tmp_path: Path) -> None:
    # brick (0, 0, 0) is empty and not stored, brick (1, 0, 0) is bright: the whole
    # volume ramps from 0 to 255 between the voxel centres at x = 7.5 and 8.5 mm
    volume = np.zeros((16, 8, 8), dtype=np.uint8)
    volume[8:] = 255
    store = small_store(tmp_path, volume)
    assert store.meta.stored_bricks == 1
    # a centre shifted by a quarter millimetre puts a column of rays at x = 7.75 mm,
    # where the whole volume holds a quarter of 255 (the reference: 90 grey)
    view = View(center=(0.5 + 0.25 / 16, 0.5))
    image, expected = one_tile(store, volume, view, VolumeLayer(volume="small", mode="mip"))
    assert expected[8, 7, 0] == 90
    assert_close(image, expected)


@pytest.mark.parametrize(
    "yaw",
    [
        pytest.param(0, id="towards+y"),
        pytest.param(180, id="towards-y"),
    ],
)
def test_a_sample_on_the_clip_box_high_face_is_left_out_whichever_way_the_ray_runs(
    tmp_path: Path, yaw: int
) -> None:
    # dim below y = 16 mm, bright above; the clip keeps y in [0, 16): the samples of the
    # rays lie at y = 16 + k mm, one exactly on the face, where the whole volume is
    # half bright; MIP shows it if that sample counts
    volume = np.full((16, 32, 16), 10, dtype=np.uint8)
    volume[:, 16:] = 255
    volume[0, 0, 0] = 0
    store = small_store(tmp_path, volume)
    layer = VolumeLayer(volume="small", mode="mip", clip=((0, 1), (0, 0.5), (0, 1)))
    image, expected = one_tile(store, volume, View(yaw=yaw), layer)
    assert_close(image, expected)


# --- the fallback ---------------------------------------------------------------------


@pytest.mark.parametrize("mode", ["composite", "mip"])
@pytest.mark.parametrize("display", DISPLAYS)
def test_the_fallback_renders_without_reading_a_brick(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, display: str, mode: Mode
) -> None:
    meta = store.meta
    view = View(yaw=30, pitch=20)
    camera, footprint = tile(store, wall, display, view)
    plan = fallback_plan(meta, footprint)
    assert plan.selection is None
    assert plan.level == meta.fallback_level == 2
    voxels = Voxels.of(store, plan)
    assert voxels.origin == (0, 0, 0)
    np.testing.assert_array_equal(voxels.values, store.fallback)
    layer = VolumeLayer(volume="blobs", mode=mode)
    image = render(voxels, meta, camera, footprint, layer, plan.scale)
    assert not store.reads
    assert image.shape == (plan.size[1], plan.size[0], 3)
    volume = whole_volume(meta, source, plan.level)
    assert_close(image, reference_render(volume, meta, camera, footprint, layer, 2, plan.scale))


# --- slices ---------------------------------------------------------------------------


def bilinear(plane: npt.NDArray[Any], x: npt.NDArray[Any], z: npt.NDArray[Any]) -> Any:
    """A 2-D plane's values at continuous (x, z) voxel coordinates, clamped."""
    x = np.clip(x, 0, plane.shape[0] - 1)
    z = np.clip(z, 0, plane.shape[1] - 1)
    x0 = np.minimum(np.floor(x).astype(int), plane.shape[0] - 2)
    z0 = np.minimum(np.floor(z).astype(int), plane.shape[1] - 2)
    fx, fz = x - x0, z - z0
    return (
        plane[x0, z0] * (1 - fx) * (1 - fz)
        + plane[x0 + 1, z0] * fx * (1 - fz)
        + plane[x0, z0 + 1] * (1 - fx) * fz
        + plane[x0 + 1, z0 + 1] * fx * fz
    )


@pytest.mark.parametrize("display", DISPLAYS)
def test_a_slice_through_the_centre_shows_the_middle_plane(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, display: str
) -> None:
    meta = store.meta
    layer = VolumeLayer(volume="blobs", mode="slice", slice=0.0)
    camera, footprint = tile(store, wall, display, View())
    plan = plan_tile(store, camera, footprint, layer, BIG_BUDGET)
    image = render(Voxels.of(store, plan), meta, camera, footprint, layer, plan.scale)
    # yaw 0 pitch 0 looks along +y with x to the right and z up: the plane through the
    # centre is y = 18 mm, halfway between the voxel centres of y = 17 and y = 18
    middle = (source[:, 17, :].astype(np.float64) + source[:, 18, :]) / 2
    w, h = footprint.pixels
    px, py = np.meshgrid(
        (np.arange(-(-w // plan.scale)) + 0.5) * plan.scale,
        (np.arange(-(-h // plan.scale)) + 0.5) * plan.scale,
    )
    a, b, c, d, e, f = footprint.to_plane
    x = meta.extent[0] / 2 + (a * px + c * py + e)
    z = meta.extent[2] / 2 - (b * px + d * py + f)
    inside = (x >= 0) & (x < meta.extent[0]) & (z >= 0) & (z < meta.extent[2])
    index = np.clip(np.rint(bilinear(middle, x - 0.5, z - 0.5)), 0, 255).astype(int)
    colour = lookup_table("grey")[index, :3] * inside[..., None]
    expected = np.clip(np.rint(colour * 255), 0, 255).astype(np.uint8)
    assert inside.any()
    assert_close(image, expected)


# not 0: at yaw 0 the centre plane lies halfway between voxel planes, where many values
# are exact ties (n + 0.5) that float32 and float64 round to neighbouring lookup entries
# (test_a_slice_through_the_centre_shows_the_middle_plane covers it)
SLICE_CASES = [
    pytest.param(
        view,
        position,
        id=f"{view_id(view)}-{position:g}",
    )
    for view in VIEWS
    for position in (-0.4, 0.1, 0.25)
]


@pytest.mark.parametrize(("view", "position"), SLICE_CASES)
def test_a_slice_matches_the_reference(
    store: VolumeStore, source: npt.NDArray[Any], wall: Wall, view: View, position: float
) -> None:
    layer = VolumeLayer(volume="blobs", mode="slice", slice=position, transfer="tissue")
    assert compare_wall(store, source, wall, view, layer, BIG_BUDGET) == {0}


def test_a_slice_reads_only_the_bricks_its_plane_passes(store: VolumeStore, wall: Wall) -> None:
    layer = VolumeLayer(volume="blobs", mode="slice")
    for display in DISPLAYS:
        camera, footprint = tile(store, wall, display, View())
        render(
            Voxels.of(store, plan_tile(store, camera, footprint, layer, BIG_BUDGET)),
            store.meta,
            camera,
            footprint,
            layer,
            1,
        )
    # the plane y = 18 mm runs through brick row j = 2 (y 16..24); row 1 (y 8..16) ends
    # exactly the margin (2 voxels) short of it and is kept; the rest are not read
    assert {j for _, j, _ in store.reads} == {1, 2}


# --- the level ------------------------------------------------------------------------


@settings(max_examples=50, deadline=None)
@given(
    counts=st.lists(st.integers(0, 10**6), min_size=1, max_size=10),
    budget=st.integers(0, 10**6),
    data=st.data(),
)
def test_finest_level_is_the_first_from_start_that_fits(
    counts: list[int], budget: int, data: st.DataObject
) -> None:
    start = data.draw(st.integers(0, len(counts) - 1), label="start")
    coarsest = data.draw(st.integers(start, len(counts) - 1), label="coarsest")
    asked: list[int] = []

    def voxels_at(level: int) -> int:
        asked.append(level)
        return counts[level]

    level = finest_level(voxels_at, start, coarsest, budget)
    fitting = [n for n in range(start, coarsest + 1) if counts[n] <= budget]
    assert level == (fitting[0] if fitting else coarsest)
    # it asks about the levels from start up to its answer, in order, and no others
    assert asked == list(range(start, level + 1))


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    yaw=st.floats(-180, 180),
    pitch=st.floats(-90, 90),
    zoom=st.floats(0.05, 6),
    center=st.tuples(st.floats(0.2, 0.8), st.floats(0.2, 0.8)),
    display=st.sampled_from(DISPLAYS),
    mode=st.sampled_from(["composite", "mip", "slice"]),
    budget=st.integers(0, 60_000),
)
def test_plan_tile_picks_the_finest_level_within_the_budget(
    shared_store: VolumeStore,
    wall: Wall,
    yaw: float,
    pitch: float,
    zoom: float,
    center: tuple[float, float],
    display: str,
    mode: Mode,
    budget: int,
) -> None:
    meta = shared_store.meta
    view = View(yaw=yaw, pitch=pitch, zoom=zoom, center=center)
    camera, footprint = tile(shared_store, wall, display, view)
    layer = VolumeLayer(volume="blobs", mode=mode)
    plan = plan_tile(shared_store, camera, footprint, layer, budget)
    start = useful_level(meta, footprint.pixel_size)
    assert start <= plan.level <= meta.levels
    if plan.level < meta.levels:
        assert plan.voxels(meta) <= budget

    def selected(level: int) -> Any:
        test = visible_test(camera, footprint, layer, meta, 2 * voxel_size(meta, level))
        return shared_store.select(test, level)

    assert plan.selection is not None
    np.testing.assert_array_equal(plan.selection.rows, selected(plan.level).rows)
    finer = plan.level - 1
    if finer >= start:
        assert selected(finer).count * meta.voxels_at(finer) > budget
    # the image has a pixel per voxel of the level, no more than the tile's pixels
    assert plan.scale == max(1, int(voxel_size(meta, plan.level) / footprint.pixel_size))
    w, h = footprint.pixels
    assert plan.size == (-(-w // plan.scale), -(-h // plan.scale))


def test_useful_level_stops_at_voxels_the_pixels_can_show(store: VolumeStore) -> None:
    meta = store.meta  # spacing 1 mm, 3 levels
    assert [useful_level(meta, size) for size in (0.3, 1.0, 1.99, 2.0, 4.0, 7.9, 8.0, 100)] == [
        0,
        0,
        0,
        1,
        2,
        2,
        3,
        3,
    ]


# --- the layer ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "clip",
    [
        ((0.5, 0.5), (0.0, 1.0), (0.0, 1.0)),
        ((0.0, 1.0), (0.7, 0.2), (0.0, 1.0)),
        ((0.0, 1.0), (0.0, 1.0), (-0.1, 1.0)),
        ((0.0, 1.1), (0.0, 1.0), (0.0, 1.0)),
        ((0.0, 1.0), (1.0, 1.0), (0.0, 1.0)),
    ],
)
def test_the_layer_refuses_a_bad_clip_interval(clip: Any) -> None:
    with pytest.raises(ValidationError, match="clip along"):
        VolumeLayer(volume="blobs", clip=clip)


@pytest.mark.parametrize(
    "fields",
    [
        {"mode": "isosurface"},
        {"transfer": "rainbow"},
        {"slice": 1.5},
        {"volume": "../etc"},
        {"volume": ""},
        {"colour": "red"},
    ],
)
def test_the_layer_refuses_unknown_modes_transfers_and_fields(fields: dict[str, Any]) -> None:
    with pytest.raises(ValidationError):
        VolumeLayer.model_validate({"volume": "blobs", **fields})


def test_the_layer_takes_the_extremes_of_its_ranges() -> None:
    layer = VolumeLayer(volume="blobs", clip=((0.0, 1.0), (0.0, 0.01), (0.99, 1.0)), slice=-1)
    assert layer.clip[2] == (0.99, 1.0)


@pytest.mark.parametrize("name", ["grey", "tissue", "hot"])
def test_every_transfer_is_black_and_clear_at_the_bottom(name: str) -> None:
    table = lookup_table(name)
    assert table.shape == (256, 4)
    assert table[0].tolist() == [0.0, 0.0, 0.0, 0.0]
    assert (table >= 0).all() and (table <= 1).all()
    assert (np.diff(table[:, 3]) >= 0).all()  # opacity never falls as values rise
