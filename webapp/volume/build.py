"""Building a brick store from a NIfTI file or a numpy array, a slab at a time.

The build never holds the volume: it reads one slab of ``brick`` slices along z,
turns each brick of the slab into its wavelet stream and appends it to the
coefficients file. A first pass over the slabs finds the value range (and whether
float data must be quantised). Peak memory is a slab, whatever the volume's size.
The store is written beside its destination and moved into place at the end, so a
failed build never leaves a half-written store behind.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from webapp.volume.store import (
    BRICKS_FILE,
    COEFFICIENTS_FILE,
    FALLBACK_FILE,
    META_FILE,
    UNIFORM,
    VolumeMeta,
    write_meta,
)
from webapp.volume.wavelet import forward, inverse, prefix_length

QUANTISED = np.uint16  # float data that is not whole numbers is stored in 16 bits
DEFAULT_BRICK = 32
DEFAULT_FALLBACK_VOXELS = 1 << 18


class VolumeBuildError(ValueError):
    """An input that cannot become a store; the message says why."""


@dataclass(frozen=True)
class Source:
    """A volume on disk, read a slab at a time with plain file reads (never whole, and
    never memory-mapped: mapped pages would stay resident).

    Slabs are cut across the axis the file stores outermost, so each is one contiguous
    read: x for C-ordered arrays, z for Fortran-ordered ones (NIfTI).
    """

    path: Path
    shape: tuple[int, int, int]
    spacing: tuple[float, float, float]
    dtype: np.dtype[Any]
    axis: int  # the slab axis
    read: Callable[[int, int], npt.NDArray[Any]]  # (start, stop) along axis -> x, y, z array

    def slabs(self, depth: int) -> Iterator[tuple[int, npt.NDArray[Any]]]:
        length = self.shape[self.axis]
        for start in range(0, length, depth):
            yield start, self.read(start, min(start + depth, length))


def open_source(path: Path, spacing: tuple[float, float, float] | None = None) -> Source:
    """A NIfTI file (``.nii``, ``.nii.gz``) or a numpy array (``.npy``)."""
    name = path.name.lower()
    if not path.is_file():
        raise VolumeBuildError(f"{path}: no such file")
    try:
        if name.endswith((".nii", ".nii.gz")):
            shape, zooms, dtype, axis, read = _nifti(path)
        elif name.endswith(".npy"):
            shape, dtype, axis, read = _npy(path)
            zooms = (1.0, 1.0, 1.0)
        else:
            raise VolumeBuildError(f"{path}: give a .nii, .nii.gz or .npy file")
    except VolumeBuildError:
        raise
    except Exception as error:  # nibabel and numpy raise many kinds on a bad file
        raise VolumeBuildError(f"{path}: cannot read it as a volume ({error})") from error
    if len(shape) != 3 or min(shape) < 1:
        raise VolumeBuildError(f"{path}: a 3-D volume is needed, this one has shape {shape}")
    if dtype.kind not in "biuf":
        raise VolumeBuildError(f"{path}: values of type {dtype} are not supported")
    given = spacing or zooms
    if len(given) != 3 or min(given) <= 0:
        raise VolumeBuildError(f"{path}: voxel spacing must be three positive numbers")
    return Source(
        path, (shape[0], shape[1], shape[2]), (given[0], given[1], given[2]), dtype, axis, read
    )


Reader = Callable[[int, int], npt.NDArray[Any]]


def _three_d(shape: tuple[int, ...]) -> tuple[int, ...]:
    """Trailing axes of length one (a 4-D file of one volume) do not count."""
    while len(shape) > 3 and shape[-1] == 1:
        shape = shape[:-1]
    return shape


def _nifti(path: Path) -> tuple[tuple[int, ...], tuple[float, ...], np.dtype[Any], int, Reader]:
    import nibabel  # only the build needs it

    image: Any = nibabel.load(path, mmap=False, keep_file_open=True)
    proxy: Any = image.dataobj
    full = tuple(int(n) for n in proxy.shape)
    shape = _three_d(full)
    extra = (0,) * (len(full) - len(shape))
    zooms = tuple(float(z) for z in image.header.get_zooms()[:3])
    dtype = np.dtype(image.get_data_dtype())
    if (getattr(proxy, "slope", 1.0), getattr(proxy, "inter", 0.0)) != (1.0, 0.0):
        dtype = np.dtype(np.float64)  # scaled on read
    axis = 2 if getattr(proxy, "order", "F") == "F" else 0

    def read(start: int, stop: int) -> npt.NDArray[Any]:
        index: list[Any] = [slice(None)] * 3
        index[axis] = slice(start, stop)
        return np.asarray(proxy[(*index, *extra)])

    return shape, zooms, dtype, axis, read


def _npy(path: Path) -> tuple[tuple[int, ...], np.dtype[Any], int, Reader]:
    with open(path, "rb") as file:
        version = np.lib.format.read_magic(file)
        if version == (1, 0):
            full, fortran, dtype = np.lib.format.read_array_header_1_0(file)
        else:
            full, fortran, dtype = np.lib.format.read_array_header_2_0(file)
        offset = file.tell()
    shape = _three_d(tuple(int(n) for n in full))
    if dtype.hasobject:
        raise VolumeBuildError(f"{path}: values of type {dtype} are not supported")
    axis = 2 if fortran else 0
    plane = int(np.prod([n for a, n in enumerate(shape) if a != axis])) if shape else 0

    def read(start: int, stop: int) -> npt.NDArray[Any]:
        count = (stop - start) * plane
        values = np.fromfile(path, dtype, count, offset=offset + start * plane * dtype.itemsize)
        if values.size != count:
            raise VolumeBuildError(f"{path}: the file ends before its data does")
        slab_shape = list(shape)
        slab_shape[axis] = stop - start
        return values.reshape(slab_shape, order="F" if fortran else "C")

    return shape, dtype, axis, read


@dataclass(frozen=True)
class _Stats:
    low: float
    high: float
    integral: bool


def build_store(
    source: Source,
    out: Path,
    *,
    name: str,
    brick: int = DEFAULT_BRICK,
    depth: int | None = None,
    empty_below: float | None = None,
    fallback_voxels: int = DEFAULT_FALLBACK_VOXELS,
    progress: Callable[[int, int], None] | None = None,
) -> VolumeMeta:
    """Build ``source`` into the store directory ``out`` (replacing a store there).

    ``depth`` fixes the octree depth (the brick side follows); otherwise bricks have
    side ``brick``. Bricks whose largest value is below ``empty_below`` (default:
    bricks of nothing but the smallest value) are not stored.
    """
    if out.exists() and not (out / META_FILE).exists() and any(out.iterdir()):
        raise VolumeBuildError(f"{out} exists and is not a volume store; not overwriting it")
    brick = _brick_side(source.shape, brick, depth)
    levels = int(math.log2(brick))
    grid = tuple(-(-n // brick) for n in source.shape)
    plan = _Plan.of(_scan(source, brick), brick, levels, empty_below)
    fallback_level = next(
        (
            level
            for level in range(levels + 1)
            if math.prod(-(-n // (1 << level)) for n in source.shape) <= fallback_voxels
        ),
        levels,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        rows, empty, fallback = _write_bricks(source, staging, plan, grid, fallback_level, progress)
        meta = VolumeMeta(
            name=name,
            source=source.path.name,
            shape=source.shape,
            spacing=source.spacing,
            brick=brick,
            levels=levels,
            grid=(grid[0], grid[1], grid[2]),
            depth=math.ceil(math.log2(max(grid))) if max(grid) > 1 else 0,
            dtype=np.dtype(plan.coefficient_type).name,
            value_range=(float(plan.low), float(plan.high)),
            background=plan.low,
            scale=plan.scale,
            offset=plan.offset,
            fallback_level=fallback_level,
            stored_bricks=len(rows),
            empty_bricks=empty,
        )
        table = np.array(rows, dtype=np.int64).reshape(-1, 6)
        np.save(staging / BRICKS_FILE, table)
        shape = meta.level_shape(fallback_level)
        np.save(staging / FALLBACK_FILE, fallback[: shape[0], : shape[1], : shape[2]].copy())
        write_meta(staging, meta)
        _replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return meta


def _brick_side(shape: tuple[int, int, int], brick: int, depth: int | None) -> int:
    """The brick side: from a fixed octree ``depth`` when given, else ``brick`` checked."""
    if depth is not None:
        if not 0 <= depth <= 12:
            raise VolumeBuildError("the octree depth must be between 0 and 12")
        longest = max(shape)
        return max(8, 1 << math.ceil(math.log2(max(1, math.ceil(longest / (1 << depth))))))
    if brick < 4 or brick & (brick - 1):
        raise VolumeBuildError("the brick side must be a power of two, at least 4")
    return brick


@dataclass(frozen=True)
class _Plan:
    """How values are stored: whole numbers as they are, other floats quantised to
    16 bits (``value = stored * scale + offset``), in the narrowest coefficient type."""

    brick: int
    levels: int
    scale: float
    offset: float
    low: int
    high: int
    threshold: int  # bricks whose largest value is below this are empty
    coefficient_type: Any

    @classmethod
    def of(cls, stats: _Stats, brick: int, levels: int, empty_below: float | None) -> _Plan:
        scale, offset = 1.0, 0.0
        if not stats.integral:
            scale = (stats.high - stats.low) / float(np.iinfo(QUANTISED).max) or 1.0
            offset = stats.low
        low = round((stats.low - offset) / scale)
        high = round((stats.high - offset) / scale)
        threshold = low + 1 if empty_below is None else math.ceil((empty_below - offset) / scale)
        return cls(brick, levels, scale, offset, low, high, threshold, _coefficient_type(low, high))


def _write_bricks(
    source: Source,
    staging: Path,
    plan: _Plan,
    grid: tuple[int, ...],
    fallback_level: int,
    progress: Callable[[int, int], None] | None,
) -> tuple[list[tuple[int, int, int, int, int, int]], int, npt.NDArray[np.int32]]:
    """Write every stored brick's coefficient stream, slab by slab; returns the brick
    table's rows, the count of empty bricks and the coarse fallback volume."""
    brick = plan.brick
    fallback_side = brick >> fallback_level
    fallback = np.full(tuple(g * fallback_side for g in grid), plan.low, dtype=np.int32)
    rows: list[tuple[int, int, int, int, int, int]] = []
    written = empty = 0
    across = [a for a in range(3) if a != source.axis]
    with open(staging / COEFFICIENTS_FILE, "wb") as coefficients:
        for slab_index, (_, slab) in enumerate(source.slabs(brick)):
            for p in range(grid[across[0]]):
                for q in range(grid[across[1]]):
                    position = [0, 0, 0]
                    position[source.axis], position[across[0]], position[across[1]] = (
                        slab_index,
                        p,
                        q,
                    )
                    i, j, k = position
                    block = _brick_of(
                        slab, position, source.axis, brick, plan.low, plan.scale, plan.offset
                    )
                    block_low, block_high = int(block.min()), int(block.max())
                    if block_high < plan.threshold:
                        empty += 1
                        continue
                    if block_low == block_high:
                        rows.append((i, j, k, UNIFORM, block_low, block_high))
                        coarse = np.full((fallback_side,) * 3, block_low, dtype=np.int32)
                    else:
                        stream = forward(block, plan.levels, plan.coefficient_type)
                        coefficients.write(stream.tobytes())
                        rows.append((i, j, k, written, block_low, block_high))
                        written += stream.size
                        coarse = inverse(
                            stream[: prefix_length(brick, fallback_level)],
                            brick,
                            plan.levels,
                            fallback_level,
                        )
                    fallback[
                        i * fallback_side : (i + 1) * fallback_side,
                        j * fallback_side : (j + 1) * fallback_side,
                        k * fallback_side : (k + 1) * fallback_side,
                    ] = coarse
            if progress is not None:
                progress(slab_index + 1, grid[source.axis])
    return rows, empty, fallback


def _scan(source: Source, depth: int) -> _Stats:
    """The value range, and whether every value is a whole number."""
    low, high = math.inf, -math.inf
    floats = source.dtype.kind == "f"
    whole = True
    for _, slab in source.slabs(depth):
        if floats:
            if not np.isfinite(slab).all():
                raise VolumeBuildError(f"{source.path}: the volume holds NaN or infinite values")
            whole = whole and bool(np.all(slab == np.round(slab)))
        low, high = min(low, float(slab.min())), max(high, float(slab.max()))
    return _Stats(low, high, whole)


def _brick_of(
    slab: npt.NDArray[Any],
    position: list[int],
    axis: int,
    side: int,
    pad: int,
    scale: float,
    offset: float,
) -> npt.NDArray[Any]:
    """The brick at grid ``position`` of a slab across ``axis``, as stored integers,
    padded to a full cube with ``pad``."""
    index = tuple(
        slice(None) if a == axis else slice(n * side, (n + 1) * side)
        for a, n in enumerate(position)
    )
    part = slab[index]
    if scale == 1.0 and offset == 0.0:
        values = part.astype(np.int64)
    else:
        values = np.round((part.astype(np.float64) - offset) / scale).astype(np.int64)
    if values.shape == (side, side, side):
        return values
    block = np.full((side, side, side), pad, dtype=np.int64)
    block[: values.shape[0], : values.shape[1], : values.shape[2]] = values
    return block


def _coefficient_type(low: int, high: int) -> type[np.signedinteger[Any]]:
    """The smallest signed type holding every coefficient: details reach 8 x the span."""
    reach = max(abs(low), abs(high), 8 * (high - low))
    if reach <= np.iinfo(np.int16).max:
        return np.int16
    if reach <= np.iinfo(np.int32).max:
        return np.int32
    raise VolumeBuildError(
        f"values from {low} to {high} span too much for lossless 32-bit coefficients"
    )


def _replace(staging: Path, out: Path) -> None:
    """Move the finished store into place; an old store there goes only after."""
    if out.exists():
        retired = out.with_name(f".{out.name}-old")
        shutil.rmtree(retired, ignore_errors=True)
        out.rename(retired)
        staging.rename(out)
        shutil.rmtree(retired, ignore_errors=True)
    else:
        staging.rename(out)
