"""The brick store on disk, and reading views of it without loading it.

A store is a directory:

* ``volume.json``: shape, voxel spacing, brick side, wavelet levels, value range and
  the coefficient type (:class:`VolumeMeta`);
* ``bricks.npy``: one row per stored brick: grid position, offset into the
  coefficients (-1 for a brick of one value), smallest and largest value;
* ``coefficients.bin``: each brick's wavelet stream, coarse first;
* ``fallback.npy``: the whole volume at a coarse level, small enough to keep in
  memory for an instant first frame.

The bricks are the leaves of an octree over the brick grid. Empty bricks (every value
below the build's threshold) are not stored, so whole empty branches vanish; a view
walks the tree from the root and descends only into branches it can see.
:class:`VolumeStore` memory-maps the coefficients and reads a brick's prefix only when
asked, and counts those reads (tests prove that unseen bricks are never touched).
"""

from __future__ import annotations

import json
import threading
from collections import Counter, OrderedDict
from collections.abc import Callable, Hashable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field

from webapp.volume.wavelet import inverse, prefix_length

FORMAT = "tagwall-volume/1"
META_FILE = "volume.json"
BRICKS_FILE = "bricks.npy"
COEFFICIENTS_FILE = "coefficients.bin"
FALLBACK_FILE = "fallback.npy"

# bricks.npy columns: i, j, k (grid position), offset, low, high
DERIVED_KEPT = 3  # assembled views kept per store (each up to the tile budget)
UNIFORM = -1  # the offset of a brick that holds one value (its low)

T = TypeVar("T")
Box = tuple[tuple[float, float, float], tuple[float, float, float]]  # world mm, min and max


class VolumeStoreError(ValueError):
    """A store directory that is missing, incomplete or of another format."""


class VolumeMeta(BaseModel):
    """What ``volume.json`` says about a store."""

    model_config = ConfigDict(extra="forbid")

    format: str = FORMAT
    name: str = Field(min_length=1, max_length=64)
    source: str
    shape: tuple[int, int, int]
    spacing: tuple[float, float, float]  # mm per voxel along x, y, z
    brick: int  # side of a brick in voxels, a power of two
    levels: int  # wavelet levels per brick (brick >> levels is the coarsest side)
    grid: tuple[int, int, int]  # bricks along x, y, z
    depth: int  # octree depth: 2**depth bricks along the longest axis
    dtype: str  # of the coefficients
    value_range: tuple[float, float]  # smallest and largest stored value
    background: int  # the value of everything not stored
    scale: float = 1.0  # physical value = stored * scale + offset
    offset: float = 0.0
    fallback_level: int
    stored_bricks: int
    empty_bricks: int

    def level_shape(self, level: int) -> tuple[int, int, int]:
        """The whole volume's voxels at ``level`` (ceil of the halvings)."""
        x, y, z = self.shape
        step = 1 << level
        return (-(-x // step), -(-y // step), -(-z // step))

    @property
    def extent(self) -> tuple[float, float, float]:
        """The volume's size in world mm."""
        return (
            self.shape[0] * self.spacing[0],
            self.shape[1] * self.spacing[1],
            self.shape[2] * self.spacing[2],
        )

    def voxels_at(self, level: int) -> int:
        """Voxels in one brick at ``level``."""
        return prefix_length(self.brick, level)


@dataclass(frozen=True)
class Selection:
    """The bricks a view needs at one level: rows of ``bricks.npy``."""

    level: int
    rows: npt.NDArray[Any]

    @property
    def count(self) -> int:
        return len(self.rows)


class VolumeStore:
    """A built volume, opened for reading: bricks come off disk only when needed."""

    def __init__(self, path: Path, *, cache_voxels: int = 1 << 26) -> None:
        self.path = path
        try:
            self.meta = VolumeMeta.model_validate_json((path / META_FILE).read_text())
            self.bricks: npt.NDArray[Any] = np.load(path / BRICKS_FILE)
            self.fallback: npt.NDArray[Any] = np.load(path / FALLBACK_FILE)
            size = (path / COEFFICIENTS_FILE).stat().st_size
            self.stamp = (path / META_FILE).stat().st_mtime_ns  # tells a rebuilt store
        except (OSError, ValueError) as error:
            raise VolumeStoreError(f"{path} is not a readable volume store: {error}") from error
        if self.meta.format != FORMAT:
            raise VolumeStoreError(f"{path}: format {self.meta.format!r}, expected {FORMAT!r}")
        self._coefficients = (
            np.memmap(path / COEFFICIENTS_FILE, dtype=self.meta.dtype, mode="r")
            if size
            else np.zeros(0, dtype=self.meta.dtype)
        )
        self.reads: Counter[tuple[int, int, int]] = Counter()
        self._cache: OrderedDict[tuple[int, int], npt.NDArray[Any]] = OrderedDict()
        self._cache_voxels = cache_voxels
        self._cached_voxels = 0
        self._lock = threading.Lock()  # tiles render in parallel threads
        self._derived: OrderedDict[Hashable, Any] = OrderedDict()
        self._tree = _Octree(self.bricks, self.meta.grid, self.meta.depth)

    @property
    def name(self) -> str:
        return self.meta.name

    def brick_box(self, row: int) -> Box:
        """World box of brick ``row``, clamped to the volume."""
        i, j, k = (int(v) for v in self.bricks[row, :3])
        return self._tree.box(i, j, k, 0, self.meta)

    def select(self, visible: Callable[[Box], bool], level: int) -> Selection:
        """The stored bricks whose box ``visible`` accepts, found by walking the octree
        (a branch whose box is not visible is never opened)."""
        rows = self._tree.walk(visible, self.meta)
        return Selection(level=level, rows=np.asarray(rows, dtype=np.int64))

    def read(self, row: int, level: int) -> npt.NDArray[Any]:
        """Brick ``row`` at ``level``: a cube of side ``brick >> level``."""
        key = (row, level)
        with self._lock:
            cached = self._cache.get(key)
            if cached is not None:
                self._cache.move_to_end(key)
                return cached
        i, j, k, offset, low, _ = (int(v) for v in self.bricks[row])
        side = self.meta.brick >> level
        if offset == UNIFORM:
            block = np.full((side, side, side), low, dtype=np.int32)
        else:
            end = offset + prefix_length(self.meta.brick, level)
            block = inverse(
                np.array(self._coefficients[offset:end]), self.meta.brick, self.meta.levels, level
            )
            with self._lock:
                self.reads[(i, j, k)] += 1
        with self._lock:
            self._remember(key, block)
        return block

    def assemble(self, selection: Selection) -> tuple[npt.NDArray[Any], tuple[int, int, int]]:
        """The selected bricks pasted into one array at the selection's level, and the
        level voxel index of its first corner; unselected space holds the background."""
        side = self.meta.brick >> selection.level
        if selection.count == 0:
            return np.full((1, 1, 1), self.meta.background, dtype=np.int32), (0, 0, 0)
        grid = self.bricks[selection.rows, :3]
        low, high = grid.min(axis=0), grid.max(axis=0) + 1
        shape = tuple(int(v) for v in (high - low) * side)
        out = np.full(shape, self.meta.background, dtype=np.int32)
        for row, (i, j, k) in zip(selection.rows, grid - low, strict=True):
            out[i * side : (i + 1) * side, j * side : (j + 1) * side, k * side : (k + 1) * side] = (
                self.read(int(row), selection.level)
            )
        origin = (int(low[0]) * side, int(low[1]) * side, int(low[2]) * side)
        return out, origin

    def memo(self, key: Hashable, make: Callable[[], T]) -> T:
        """What ``make`` derives from this store, kept for the next few asks (the voxels
        a view assembled: the next view often needs the same bricks)."""
        with self._lock:
            if key in self._derived:
                self._derived.move_to_end(key)
                return self._derived[key]  # type: ignore[no-any-return]
        value = make()
        with self._lock:
            self._derived[key] = value
            while len(self._derived) > DERIVED_KEPT:
                self._derived.popitem(last=False)
        return value

    def _remember(self, key: tuple[int, int], block: npt.NDArray[Any]) -> None:
        self._cache[key] = block
        self._cached_voxels += block.size
        while self._cached_voxels > self._cache_voxels and len(self._cache) > 1:
            _, dropped = self._cache.popitem(last=False)
            self._cached_voxels -= dropped.size


class _Octree:
    """The octree over the brick grid: node (i, j, k) at height h covers the
    ``2**h``-cube of bricks starting at (i, j, k) * 2**h; leaves are the bricks."""

    def __init__(self, bricks: npt.NDArray[Any], grid: tuple[int, int, int], depth: int):
        self.depth = depth
        self.leaves: dict[tuple[int, int, int], int] = {
            (int(b[0]), int(b[1]), int(b[2])): row for row, b in enumerate(bricks)
        }
        # occupied[h] holds the nodes at height h with at least one stored brick below
        occupied: list[set[tuple[int, int, int]]] = [set(self.leaves)]
        for _ in range(depth):
            occupied.append({(i >> 1, j >> 1, k >> 1) for i, j, k in occupied[-1]})
        self.occupied = occupied

    def box(self, i: int, j: int, k: int, height: int, meta: VolumeMeta) -> Box:
        span = meta.brick << height
        low = tuple(index * span * meta.spacing[axis] for axis, index in enumerate((i, j, k)))
        high = tuple(
            min(meta.extent[axis], (index + 1) * span * meta.spacing[axis])
            for axis, index in enumerate((i, j, k))
        )
        return (low[0], low[1], low[2]), (high[0], high[1], high[2])

    def walk(self, visible: Callable[[Box], bool], meta: VolumeMeta) -> list[int]:
        rows: list[int] = []
        for node in self._visit(visible, meta, (0, 0, 0), self.depth):
            rows.append(self.leaves[node])
        return sorted(rows)

    def _visit(
        self,
        visible: Callable[[Box], bool],
        meta: VolumeMeta,
        node: tuple[int, int, int],
        height: int,
    ) -> Iterator[tuple[int, int, int]]:
        if node not in self.occupied[height] or not visible(self.box(*node, height, meta)):
            return
        if height == 0:
            yield node
            return
        i, j, k = node
        for child in range(8):
            yield from self._visit(
                visible,
                meta,
                (2 * i + (child & 1), 2 * j + ((child >> 1) & 1), 2 * k + (child >> 2)),
                height - 1,
            )


def write_meta(path: Path, meta: VolumeMeta) -> None:
    (path / META_FILE).write_text(json.dumps(meta.model_dump(), indent=2) + "\n")
