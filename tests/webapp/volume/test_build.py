"""Building a brick store from .npy and NIfTI files, a slab at a time."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import nibabel
import numpy as np
import numpy.typing as npt
import pytest

from webapp.volume.build import VolumeBuildError, build_store, open_source
from webapp.volume.store import UNIFORM, VolumeMeta, VolumeStore
from webapp.volume.wavelet import downsample

SHAPE = (40, 36, 28)  # not a multiple of the brick side along any axis


def save(path: Path, volume: npt.NDArray[Any]) -> Path:
    np.save(path, volume)
    return path


def build(
    tmp_path: Path, volume: npt.NDArray[Any], name: str = "vol", **options: Any
) -> tuple[VolumeMeta, VolumeStore]:
    source = save(tmp_path / f"{name}.npy", volume)
    options.setdefault("brick", 8)
    meta = build_store(open_source(source), tmp_path / "stores" / name, name=name, **options)
    return meta, VolumeStore(tmp_path / "stores" / name)


def stored_voxels(store: VolumeStore) -> npt.NDArray[Any]:
    """Every stored brick at level 0 pasted in place, cropped to the volume's shape."""
    meta = store.meta
    selection = store.select(lambda box: True, 0)
    values, origin = store.assemble(selection)
    whole = np.full(tuple(g * meta.brick for g in meta.grid), meta.background, dtype=np.int64)
    x, y, z = origin
    whole[x : x + values.shape[0], y : y + values.shape[1], z : z + values.shape[2]] = values
    return whole[: meta.shape[0], : meta.shape[1], : meta.shape[2]]


def padded(volume: npt.NDArray[Any], meta: VolumeMeta) -> npt.NDArray[Any]:
    """The volume padded with the background to whole bricks."""
    out = np.full(tuple(g * meta.brick for g in meta.grid), meta.background, dtype=np.int64)
    out[: volume.shape[0], : volume.shape[1], : volume.shape[2]] = volume
    return out


def random_volume(shape: tuple[int, int, int] = SHAPE, seed: int = 3) -> npt.NDArray[Any]:
    return np.random.default_rng(seed).integers(0, 256, size=shape).astype(np.uint8)


def test_assembled_bricks_reproduce_the_original_voxels(tmp_path: Path) -> None:
    volume = random_volume()
    meta, store = build(tmp_path, volume)
    assert meta.shape == SHAPE
    assert meta.grid == (5, 5, 4)
    assert meta.brick == 8 and meta.levels == 3
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_signed_values_reproduce_exactly(tmp_path: Path) -> None:
    rng = np.random.default_rng(4)
    volume = rng.integers(-3000, 3000, size=(17, 9, 23)).astype(np.int16)
    meta, store = build(tmp_path, volume)
    assert meta.value_range == (float(volume.min()), float(volume.max()))
    assert meta.background == int(volume.min())
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_empty_bricks_are_not_stored(tmp_path: Path) -> None:
    volume = np.zeros(SHAPE, dtype=np.uint8)
    volume[3:12, 20:30, 5:9] = np.random.default_rng(1).integers(1, 255, size=(9, 10, 4))
    meta, store = build(tmp_path, volume)
    # x 3..11 -> bricks 0, 1; y 20..29 -> bricks 2, 3; z 5..8 -> bricks 0, 1
    occupied = {(i, j, k) for i in (0, 1) for j in (2, 3) for k in (0, 1)}
    assert {tuple(int(v) for v in row[:3]) for row in store.bricks} == occupied
    assert meta.stored_bricks == len(store.bricks) == len(occupied)
    assert meta.empty_bricks == math.prod(meta.grid) - len(occupied)
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_a_brick_of_one_value_is_stored_as_uniform_and_reads_back(tmp_path: Path) -> None:
    volume = np.maximum(random_volume(), 1)
    volume[0, 0, 0] = 0  # the background
    volume[8:16, 16:24, 0:8] = 77  # brick (1, 2, 0): one value, not the background
    meta, store = build(tmp_path, volume)
    assert meta.background == 0
    rows = [n for n, row in enumerate(store.bricks) if tuple(row[:3]) == (1, 2, 0)]
    assert len(rows) == 1
    i, j, k, offset, low, high = (int(v) for v in store.bricks[rows[0]])
    assert (offset, low, high) == (UNIFORM, 77, 77)
    for level in range(meta.levels + 1):
        side = meta.brick >> level
        np.testing.assert_array_equal(store.read(rows[0], level), np.full((side,) * 3, 77))
    assert store.reads[(i, j, k)] == 0  # nothing came off disk for it
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_other_bricks_record_their_value_range(tmp_path: Path) -> None:
    volume = random_volume()
    _, store = build(tmp_path, volume)
    for i, j, k, offset, low, high in store.bricks:
        part = volume[i * 8 : i * 8 + 8, j * 8 : j * 8 + 8, k * 8 : k * 8 + 8]
        assert offset >= 0
        # a partial brick is padded with the background (the volume's smallest value)
        full = part.size == 8**3
        assert low == (part.min() if full else min(int(part.min()), int(volume.min())))
        assert high == part.max()


@pytest.mark.parametrize("fallback_voxels", [1 << 20, 20_000, 4_000, 100, 1])
def test_fallback_is_the_padded_volume_downsampled(tmp_path: Path, fallback_voxels: int) -> None:
    volume = random_volume()
    volume[:16, :, :] = 0  # some empty bricks too
    meta, store = build(tmp_path, volume, fallback_voxels=fallback_voxels)
    level = meta.fallback_level
    assert math.prod(meta.level_shape(level)) <= fallback_voxels or level == meta.levels
    if level > 0:
        assert math.prod(meta.level_shape(level - 1)) > fallback_voxels
    fallback = np.load(tmp_path / "stores" / "vol" / "fallback.npy")
    x, y, z = meta.level_shape(level)
    expected = downsample(padded(volume, meta), level)[:x, :y, :z]
    assert fallback.shape == (x, y, z)
    np.testing.assert_array_equal(fallback, expected)
    np.testing.assert_array_equal(store.fallback, expected)


def test_float_volume_of_whole_numbers_stays_exact(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    volume = rng.integers(-50, 400, size=SHAPE).astype(np.float32)
    meta, store = build(tmp_path, volume)
    assert (meta.scale, meta.offset) == (1.0, 0.0)
    assert meta.value_range == (float(volume.min()), float(volume.max()))
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_float_volume_with_fractions_is_quantised_within_half_a_step(tmp_path: Path) -> None:
    rng = np.random.default_rng(6)
    volume = rng.normal(3.0, 2.5, size=SHAPE)
    meta, store = build(tmp_path, volume)
    assert meta.scale != 1.0
    assert meta.offset == pytest.approx(volume.min())
    assert meta.scale == pytest.approx((volume.max() - volume.min()) / 65535)
    stored = stored_voxels(store)
    assert stored.min() >= 0 and stored.max() <= 65535
    restored = stored * meta.scale + meta.offset
    error = np.abs(restored - volume)
    assert error.max() <= meta.scale / 2 * (1 + 1e-6)


def test_nifti_input_is_read_with_its_voxel_spacing(tmp_path: Path) -> None:
    volume = random_volume((20, 12, 10)).astype(np.int16)
    path = tmp_path / "scan.nii.gz"
    nibabel.save(nibabel.Nifti1Image(volume, np.diag([2.0, 2.0, 2.0, 1.0])), path)
    source = open_source(path)
    assert source.shape == (20, 12, 10)
    assert source.spacing == (2.0, 2.0, 2.0)
    meta = build_store(source, tmp_path / "scan", name="scan", brick=8)
    assert meta.spacing == (2.0, 2.0, 2.0)
    assert meta.extent == (40.0, 24.0, 20.0)
    assert meta.source == "scan.nii.gz"
    np.testing.assert_array_equal(stored_voxels(VolumeStore(tmp_path / "scan")), volume)


def test_scaled_nifti_values_are_read_scaled_and_quantised(tmp_path: Path) -> None:
    image = nibabel.Nifti1Image(
        np.random.default_rng(0).normal(0.0, 3.0, (10, 8, 6)), np.diag([1.5, 1.0, 0.5, 1.0])
    )
    image.set_data_dtype(np.int16)  # nibabel stores int16 with a slope and an intercept
    path = tmp_path / "scaled.nii.gz"
    nibabel.save(image, path)
    on_read = np.asarray(nibabel.load(path).dataobj)
    assert on_read.dtype.kind == "f" and not np.all(on_read == np.round(on_read))
    source = open_source(path)
    assert source.dtype == np.float64
    assert source.spacing == (1.5, 1.0, 0.5)
    meta = build_store(source, tmp_path / "scaled", name="scaled", brick=8)
    assert meta.scale != 1.0
    stored = stored_voxels(VolumeStore(tmp_path / "scaled"))
    error = np.abs(stored * meta.scale + meta.offset - on_read)
    assert error.max() <= meta.scale / 2 * (1 + 1e-6)


def test_trailing_unit_axes_are_dropped(tmp_path: Path) -> None:
    volume = random_volume((10, 9, 7))
    source = open_source(save(tmp_path / "v.npy", volume[..., None, None]))
    assert source.shape == (10, 9, 7)
    build_store(source, tmp_path / "out", name="v", brick=8)
    np.testing.assert_array_equal(stored_voxels(VolumeStore(tmp_path / "out")), volume)


def test_given_spacing_overrides_the_files(tmp_path: Path) -> None:
    source = open_source(save(tmp_path / "v.npy", random_volume()), spacing=(0.5, 1.0, 2.5))
    assert source.spacing == (0.5, 1.0, 2.5)


def test_a_missing_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(VolumeBuildError, match="no such file"):
        open_source(tmp_path / "absent.npy")


def test_a_file_of_another_kind_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "volume.txt"
    path.write_text("1 2 3\n")
    with pytest.raises(VolumeBuildError, match=r"\.nii, \.nii\.gz or \.npy"):
        open_source(path)


def test_an_unreadable_npy_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "broken.npy"
    path.write_bytes(b"not a numpy file")
    with pytest.raises(VolumeBuildError, match="cannot read it as a volume"):
        open_source(path)


def test_a_2d_array_is_refused(tmp_path: Path) -> None:
    path = save(tmp_path / "flat.npy", np.zeros((10, 12), dtype=np.uint8))
    with pytest.raises(VolumeBuildError, match=r"3-D volume is needed.*\(10, 12\)"):
        open_source(path)


def test_nan_values_are_refused(tmp_path: Path) -> None:
    volume = np.random.default_rng(2).random(SHAPE)
    volume[30, 20, 25] = np.nan
    source = open_source(save(tmp_path / "nan.npy", volume))
    with pytest.raises(VolumeBuildError, match="NaN"):
        build_store(source, tmp_path / "out", name="nan", brick=8)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("brick", [12, 6, 2, 0])
def test_a_brick_side_that_is_not_a_power_of_two_is_refused(tmp_path: Path, brick: int) -> None:
    source = open_source(save(tmp_path / "v.npy", random_volume()))
    with pytest.raises(VolumeBuildError, match="power of two"):
        build_store(source, tmp_path / "out", name="v", brick=brick)


def test_a_directory_that_is_not_a_store_is_left_untouched(tmp_path: Path) -> None:
    out = tmp_path / "precious"
    out.mkdir()
    (out / "notes.txt").write_text("keep me\n")
    (out / "sub").mkdir()
    (out / "sub" / "data.bin").write_bytes(b"\x00\x01")
    source = open_source(save(tmp_path / "v.npy", random_volume()))
    with pytest.raises(VolumeBuildError, match="not a volume store"):
        build_store(source, out, name="v", brick=8)
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == [
        "notes.txt",
        "sub",
        "sub/data.bin",
    ]
    assert (out / "notes.txt").read_text() == "keep me\n"
    assert (out / "sub" / "data.bin").read_bytes() == b"\x00\x01"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["precious", "v.npy"]


def test_an_empty_existing_directory_becomes_the_store(tmp_path: Path) -> None:
    out = tmp_path / "empty"
    out.mkdir()
    volume = random_volume()
    build_store(open_source(save(tmp_path / "v.npy", volume)), out, name="v", brick=8)
    np.testing.assert_array_equal(stored_voxels(VolumeStore(out)), volume)


def test_rebuilding_replaces_the_store_and_leaves_no_staging(tmp_path: Path) -> None:
    first = random_volume(seed=1)
    second = random_volume((24, 20, 16), seed=2)
    build(tmp_path, first)
    meta, store = build(tmp_path, second)
    assert meta.shape == (24, 20, 16)
    np.testing.assert_array_equal(stored_voxels(store), second)
    assert [p.name for p in (tmp_path / "stores").iterdir()] == ["vol"]
    assert sorted(p.name for p in (tmp_path / "stores" / "vol").iterdir()) == [
        "bricks.npy",
        "coefficients.bin",
        "fallback.npy",
        "volume.json",
    ]


def test_a_failed_rebuild_keeps_the_old_store_and_leaves_no_staging(tmp_path: Path) -> None:
    first = random_volume(seed=1)
    build(tmp_path, first)

    def fail(done: int, total: int) -> None:
        if done == 2:
            raise RuntimeError("interrupted")

    source = open_source(save(tmp_path / "next.npy", random_volume(seed=9)))
    with pytest.raises(RuntimeError, match="interrupted"):
        build_store(source, tmp_path / "stores" / "vol", name="vol", brick=8, progress=fail)
    assert [p.name for p in (tmp_path / "stores").iterdir()] == ["vol"]
    np.testing.assert_array_equal(stored_voxels(VolumeStore(tmp_path / "stores" / "vol")), first)


def test_progress_counts_every_slab_up_to_the_total(tmp_path: Path) -> None:
    calls: list[tuple[int, int]] = []
    meta, _ = build(
        tmp_path, random_volume(), progress=lambda done, total: calls.append((done, total))
    )
    # slabs are a brick thick, across one axis (whichever the file stores outermost)
    total = calls[-1][1]
    assert total in meta.grid
    assert calls == [(done, total) for done in range(1, total + 1)]


def test_a_fortran_ordered_array_reproduces_exactly(tmp_path: Path) -> None:
    volume = random_volume()
    _, store = build(tmp_path, np.asfortranarray(volume))
    np.testing.assert_array_equal(stored_voxels(store), volume)


def test_a_truncated_npy_is_refused(tmp_path: Path) -> None:
    path = save(tmp_path / "cut.npy", random_volume())
    path.write_bytes(path.read_bytes()[:-100])
    with pytest.raises(VolumeBuildError, match="ends before its data"):
        build_store(open_source(path), tmp_path / "out", name="cut", brick=8)
    assert not (tmp_path / "out").exists()
    assert [p.name for p in tmp_path.iterdir()] == ["cut.npy"]


@pytest.mark.parametrize(
    ("depth", "brick", "tree_depth"),
    [(2, 16, 2), (3, 8, 3), (1, 32, 1), (0, 64, 0), (5, 8, 3)],
)
def test_depth_sets_the_brick_side(tmp_path: Path, depth: int, brick: int, tree_depth: int) -> None:
    # the longest side is 40: depth 2 wants 40 / 4 = 10 voxels a brick, rounded up to 16;
    # bricks never get smaller than 8
    volume = random_volume()
    meta, store = build(tmp_path, volume, depth=depth, brick=4)
    assert meta.brick == brick
    assert meta.levels == int(math.log2(brick))
    assert meta.grid == tuple(-(-n // brick) for n in SHAPE)
    assert meta.depth == tree_depth
    np.testing.assert_array_equal(stored_voxels(store), volume)


@pytest.mark.parametrize("depth", [-1, 13])
def test_a_depth_outside_0_to_12_is_refused(tmp_path: Path, depth: int) -> None:
    source = open_source(save(tmp_path / "v.npy", random_volume()))
    with pytest.raises(VolumeBuildError, match="depth must be between 0 and 12"):
        build_store(source, tmp_path / "out", name="v", depth=depth)


def test_empty_below_drops_bricks_whose_values_stay_low(tmp_path: Path) -> None:
    rng = np.random.default_rng(8)
    volume = rng.integers(0, 10, size=SHAPE).astype(np.uint8)  # faint noise everywhere
    volume[8:16, 0:8, 8:16] = rng.integers(0, 200, size=(8, 8, 8))  # brick (1, 0, 1)
    volume[8:16, 0:8, 8:16][0, 0, 0] = 150
    volume[33, 30, 20] = 60  # one bright voxel in brick (4, 3, 2)
    meta, store = build(tmp_path, volume, empty_below=50)
    kept = {tuple(int(v) for v in row[:3]) for row in store.bricks}
    assert kept == {(1, 0, 1), (4, 3, 2)}
    assert meta.stored_bricks == 2
    assert meta.empty_bricks == math.prod(meta.grid) - 2
    # without the option every brick of the noise is kept
    meta_all, _ = build(tmp_path, volume, name="all")
    assert meta_all.stored_bricks == math.prod(meta.grid)


def test_values_of_an_unsupported_type_are_refused(tmp_path: Path) -> None:
    path = save(tmp_path / "complex.npy", np.zeros((4, 4, 4), dtype=np.complex64))
    with pytest.raises(VolumeBuildError, match="not supported"):
        open_source(path)
