"""Reading a store: the octree finds the bricks a tile sees, and only those are read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from wall_client.config import parse_wall
from wall_client.layout import Wall
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.build import build_store, open_source
from webapp.volume.render import (
    Camera,
    Footprint,
    TilePlan,
    Voxels,
    plan_tile,
    render,
    voxel_size,
)
from webapp.volume.store import (
    BRICKS_FILE,
    COEFFICIENTS_FILE,
    FALLBACK_FILE,
    META_FILE,
    Box,
    VolumeStore,
    VolumeStoreError,
)

SIDE = 64
BRICK = 8
BUDGET = 1 << 20  # level 0 for a tile: at most 8 * 8 * 8 bricks of 512 voxels
WALL: dict[str, Any] = {
    "id": "t",
    "name": "t",
    "screens": {"registration": []},  # no panels: the picture is framed on the whole wall
    "grid": {
        "columns": 2,
        "rows": 1,
        "resolution": [64, 48],
        "active_mm": [400, 300],
        "bezel_mm": 0,
    },
}


@pytest.fixture(scope="module")
def store_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 64^3 volume with content everywhere: every one of its 8^3 bricks is stored,
    none of them uniform (so every read comes off the coefficients file)."""
    base = tmp_path_factory.mktemp("store")
    volume = np.random.default_rng(12).integers(1, 256, size=(SIDE,) * 3).astype(np.uint8)
    volume[0, 0, 0] = 0
    np.save(base / "cube.npy", volume)
    build_store(open_source(base / "cube.npy"), base / "cube", name="cube", brick=BRICK)
    return base / "cube"


@pytest.fixture
def store(store_path: Path) -> VolumeStore:
    """A freshly opened store: no reads counted, nothing cached."""
    return VolumeStore(store_path)


@pytest.fixture(scope="module")
def wall() -> Wall:
    return parse_wall(WALL)


def grid_of(store: VolumeStore, row: int) -> tuple[int, int, int]:
    i, j, k = (int(v) for v in store.bricks[row, :3])
    return i, j, k


def box_of(store: VolumeStore, brick: tuple[int, int, int]) -> Box:
    """A brick's world box, computed here from its grid position."""
    meta = store.meta
    low = [brick[a] * meta.brick * meta.spacing[a] for a in range(3)]
    high = [min(meta.extent[a], (brick[a] + 1) * meta.brick * meta.spacing[a]) for a in range(3)]
    return (low[0], low[1], low[2]), (high[0], high[1], high[2])


def meets_footprint(camera: Camera, footprint: Footprint, box: Box, margin: float) -> bool:
    """Whether the box's projection overlaps the footprint's bounds widened by margin."""
    corners = np.array([[box[(n >> a) & 1][a] for a in range(3)] for n in range(8)])
    u, v, _ = camera.project(corners)
    u0, u1, v0, v1 = footprint.bounds
    return bool(
        u.max() >= u0 - margin
        and u.min() <= u1 + margin
        and v.max() >= v0 - margin
        and v.min() <= v1 + margin
    )


def render_tile(
    store: VolumeStore, wall: Wall, display: str, view: View
) -> tuple[Camera, Footprint, TilePlan]:
    camera = Camera.looking(store.meta, view.yaw, view.pitch)
    footprint = Footprint.of(wall.viewport(display), view, wall.stage, store.meta)
    layer = VolumeLayer(volume="cube")
    plan = plan_tile(store, camera, footprint, layer, BUDGET)
    render(Voxels.of(store, plan), store.meta, camera, footprint, layer, plan.scale)
    return camera, footprint, plan


VIEWS = [
    View(),
    View(yaw=30, pitch=20),
    View(yaw=90, pitch=-40, zoom=1.5),
    View(yaw=-20, pitch=70, zoom=2, center=(0.45, 0.6)),
    View(yaw=10, zoom=3, center=(0.3, 0.5)),
]


@pytest.mark.parametrize("display", ["r1c1", "r1c2"])
@pytest.mark.parametrize("view", VIEWS, ids=lambda v: f"{v.yaw}/{v.pitch}x{v.zoom}")
def test_a_tile_reads_no_brick_outside_its_footprint(
    store: VolumeStore, wall: Wall, display: str, view: View
) -> None:
    camera, footprint, plan = render_tile(store, wall, display, view)
    assert plan.level == 0 and plan.selection is not None
    margin = 2 * voxel_size(store.meta, plan.level)
    read = set(store.reads)
    outside = {
        grid_of(store, row)
        for row in range(len(store.bricks))
        if not meets_footprint(camera, footprint, box_of(store, grid_of(store, row)), margin)
    }
    assert outside, "the view should leave some bricks out"
    assert not read & outside
    assert all(count == 1 for count in store.reads.values())


@pytest.mark.parametrize("display", ["r1c1", "r1c2"])
@pytest.mark.parametrize("view", VIEWS, ids=lambda v: f"{v.yaw}/{v.pitch}x{v.zoom}")
def test_a_tile_reads_every_brick_its_footprint_meets(
    store: VolumeStore, wall: Wall, display: str, view: View
) -> None:
    camera, footprint, plan = render_tile(store, wall, display, view)
    margin = 2 * voxel_size(store.meta, plan.level)
    needed = {
        grid_of(store, row)
        for row in range(len(store.bricks))
        if meets_footprint(camera, footprint, box_of(store, grid_of(store, row)), margin)
    }
    assert set(store.reads) == needed


def test_the_left_tile_does_not_read_the_right_half(store: VolumeStore, wall: Wall) -> None:
    # yaw 0 looks along +y with +x to the right: the seam between the tiles runs through
    # the volume's centre, x = 32 mm, between brick columns i = 3 and i = 4
    render_tile(store, wall, "r1c1", View())
    columns = {i for i, _, _ in store.reads}
    # column 4 lies within the margin (2 voxels) of the seam, so it is read too; the
    # columns beyond it are not
    assert columns == {0, 1, 2, 3, 4}
    assert len(store.reads) == 5 * 8 * 8


def test_the_right_tile_does_not_read_the_left_half(store: VolumeStore, wall: Wall) -> None:
    render_tile(store, wall, "r1c2", View())
    assert {i for i, _, _ in store.reads} == {3, 4, 5, 6, 7}


def test_reading_a_brick_twice_reads_the_file_once(store: VolumeStore) -> None:
    first = store.read(10, 0)
    second = store.read(10, 0)
    assert store.reads == {grid_of(store, 10): 1}
    np.testing.assert_array_equal(first, second)


def test_each_level_of_a_brick_is_read_once(store: VolumeStore) -> None:
    store.read(10, 0)
    store.read(10, 2)
    store.read(10, 2)
    store.read(10, 0)
    assert store.reads == {grid_of(store, 10): 2}


def test_a_brick_dropped_from_a_full_cache_is_read_again(store_path: Path) -> None:
    store = VolumeStore(store_path, cache_voxels=BRICK**3)  # room for one brick
    store.read(1, 0)
    store.read(2, 0)  # pushes brick 1 out
    store.read(1, 0)
    assert store.reads[grid_of(store, 1)] == 2
    assert store.reads[grid_of(store, 2)] == 1


def test_read_bricks_hold_the_source_voxels(store: VolumeStore, store_path: Path) -> None:
    volume: npt.NDArray[Any] = np.load(store_path.parent / "cube.npy")
    for row in (0, 77, len(store.bricks) - 1):
        i, j, k = grid_of(store, row)
        np.testing.assert_array_equal(
            store.read(row, 0), volume[i * 8 : i * 8 + 8, j * 8 : j * 8 + 8, k * 8 : k * 8 + 8]
        )


def test_a_predicate_that_rejects_everything_reads_nothing(store: VolumeStore) -> None:
    asked: list[Box] = []

    def nothing(box: Box) -> bool:
        asked.append(box)
        return False

    selection = store.select(nothing, 0)
    assert selection.count == 0
    assert asked == [((0.0, 0.0, 0.0), (64.0, 64.0, 64.0))]  # the root, never its children
    values, origin = store.assemble(selection)
    assert values.shape == (1, 1, 1) and origin == (0, 0, 0)
    assert not store.reads


def test_select_opens_only_the_branches_it_accepts(store: VolumeStore) -> None:
    asked: list[Box] = []

    def first_octant(box: Box) -> bool:
        asked.append(box)
        return all(high <= 32 for high in box[1])

    # the root (0..64) is rejected, so nothing below it is looked at
    assert store.select(first_octant, 0).count == 0
    assert len(asked) == 1

    def low_corner(box: Box) -> bool:
        return all(low < 16 for low in box[0])

    selection = store.select(low_corner, 1)
    assert selection.level == 1
    assert {grid_of(store, int(row)) for row in selection.rows} == {
        (i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)
    }
    assert not store.reads  # selecting reads no brick


@pytest.mark.parametrize("missing", [META_FILE, BRICKS_FILE, COEFFICIENTS_FILE, FALLBACK_FILE])
def test_a_store_with_a_missing_file_is_refused(
    tmp_path: Path, store_path: Path, missing: str
) -> None:
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in (META_FILE, BRICKS_FILE, COEFFICIENTS_FILE, FALLBACK_FILE):
        if name != missing:
            (broken / name).write_bytes((store_path / name).read_bytes())
    with pytest.raises(VolumeStoreError, match="not a readable volume store"):
        VolumeStore(broken)


def test_a_missing_store_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(VolumeStoreError):
        VolumeStore(tmp_path / "nowhere")


def test_a_store_of_another_format_is_refused(tmp_path: Path, store_path: Path) -> None:
    other = tmp_path / "other"
    other.mkdir()
    for name in (BRICKS_FILE, COEFFICIENTS_FILE, FALLBACK_FILE):
        (other / name).write_bytes((store_path / name).read_bytes())
    meta = (store_path / META_FILE).read_text().replace("tagwall-volume/1", "tagwall-volume/9")
    (other / META_FILE).write_text(meta)
    with pytest.raises(VolumeStoreError, match="format"):
        VolumeStore(other)
