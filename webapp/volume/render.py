"""A tile's part of a volume: the bricks it sees, the level it can afford, the image.

The wall is one orthographic camera. Its image plane passes through the volume's
centre; ``u`` runs right and ``v`` down, in world millimetres. The wall's view places
the volume on the scene exactly as it places every other layer: at zoom 1 and centre
(0.5, 0.5) the volume's longest side spans the scene's shorter side, centred. Each
tile maps its pixels through its viewport onto that plane (its *footprint*), so the
tiles' images fit together into one image of the wall, whatever the bezel mode.

For a footprint, the octree gives the bricks whose projection meets it; the level is
the finest whose voxels fit the tile's budget (and no finer than its pixels can
show); rays are cast one per voxel of that level across the footprint, sampled once
per voxel along the view, trilinearly, and composited front to back (or reduced to
their maximum, or cut by a slice). The browser stretches the result over the tile.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from wall_client.layout import (
    Affine,
    Rect,
    Viewport,
    apply_affine,
    compose_affine,
    invert_affine,
)
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.store import Box, Selection, VolumeMeta, VolumeStore
from webapp.volume.transfer import lookup_table

Vector = npt.NDArray[Any]
Image = npt.NDArray[Any]
OPAQUE = 0.996  # a ray this opaque shows nothing behind
CELL = 4  # voxels per side of the blocks empty-space skipping tests


@dataclass(frozen=True)
class Camera:
    """The wall's orthographic camera in world mm: screen axes, view direction, centre."""

    right: Vector
    down: Vector
    forward: Vector
    centre: Vector

    @classmethod
    def looking(cls, meta: VolumeMeta, yaw: float, pitch: float) -> Camera:
        """Yaw 0, pitch 0 looks along +y with +x to the right and +z up; yaw turns the
        camera about z, positive pitch looks down from above."""
        psi, theta = math.radians(yaw), math.radians(pitch)
        turn = np.array(
            [[math.cos(psi), -math.sin(psi), 0.0], [math.sin(psi), math.cos(psi), 0.0], [0, 0, 1]]
        )
        forward = turn @ np.array([0.0, math.cos(theta), -math.sin(theta)])
        up = turn @ np.array([0.0, math.sin(theta), math.cos(theta)])
        right = turn @ np.array([1.0, 0.0, 0.0])
        return cls(right, -up, forward, np.array(meta.extent) / 2)

    def project(self, points: Vector) -> tuple[Vector, Vector, Vector]:
        """(u, v, depth) of world points, relative to the centre."""
        relative = points - self.centre
        return relative @ self.right, relative @ self.down, relative @ self.forward


def scene_to_plane(view: View, frame: Rect, meta: VolumeMeta) -> Affine:
    """Scene mm (x, y) -> image plane (u, v) in world mm, for ``view`` of a picture
    framed on ``frame`` (the wall's stage, scene mm): at zoom 1 and centre (0.5, 0.5)
    the volume's longest side spans the frame's shorter side, centred on the frame.
    The one home of this map: tiles' footprints and anything placed on the picture
    (pins) go through it (or its inverse)."""
    k = max(meta.extent) / min(frame.width, frame.height)  # world mm per scene mm at zoom 1
    zoom = view.zoom
    cx, cy = view.center
    return (
        k / zoom,
        0.0,
        0.0,
        k / zoom,
        k * ((cx - 0.5) * frame.width - frame.width / (2 * zoom) - frame.x / zoom),
        k * ((cy - 0.5) * frame.height - frame.height / (2 * zoom) - frame.y / zoom),
    )


@dataclass(frozen=True)
class Footprint:
    """A tile on the image plane: its pixel (x, y) -> plane (u, v) map and size."""

    to_plane: Affine
    pixels: tuple[int, int]

    @classmethod
    def of(cls, viewport: Viewport, view: View, frame: Rect, meta: VolumeMeta) -> Footprint:
        to_plane = compose_affine(
            scene_to_plane(view, frame, meta), invert_affine(viewport.to_pixels)
        )
        return cls(to_plane, viewport.pixels)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(u_min, u_max, v_min, v_max) of the tile's corners."""
        w, h = self.pixels
        corners = [apply_affine(self.to_plane, x, y) for x in (0, w) for y in (0, h)]
        us, vs = [c[0] for c in corners], [c[1] for c in corners]
        return min(us), max(us), min(vs), max(vs)

    @property
    def pixel_size(self) -> float:
        """Plane mm per tile pixel."""
        a, b, c, d, _, _ = self.to_plane
        return math.sqrt(abs(a * d - b * c))


@dataclass(frozen=True)
class TilePlan:
    """What one tile renders: the level, its bricks (None: the in-memory fallback)
    and the image size, ``scale`` tile pixels per image pixel."""

    level: int
    selection: Selection | None
    scale: int
    size: tuple[int, int]

    def voxels(self, meta: VolumeMeta) -> int:
        if self.selection is None:
            return math.prod(meta.level_shape(self.level))
        return self.selection.count * meta.voxels_at(self.level)


def voxel_size(meta: VolumeMeta, level: int) -> float:
    """The finest edge of a voxel at ``level``, mm."""
    return min(meta.spacing) * (1 << level)


def useful_level(meta: VolumeMeta, pixel_size: float) -> int:
    """The coarsest level whose voxels are still no bigger than a pixel: anything
    finer would be averaged away on screen."""
    ratio = pixel_size / min(meta.spacing)
    return 0 if ratio < 2 else min(meta.levels, int(math.log2(ratio)))


def finest_level(voxels_at: Callable[[int], int], start: int, coarsest: int, budget: int) -> int:
    """The finest level from ``start`` whose voxel count fits ``budget``; the coarsest
    when none does (a tile always shows something)."""
    for level in range(start, coarsest + 1):
        if voxels_at(level) <= budget:
            return level
    return coarsest


def visible_test(
    camera: Camera, footprint: Footprint, layer: VolumeLayer, meta: VolumeMeta, margin: float
) -> Callable[[Box], bool]:
    """Whether a world box can contribute to the footprint: its projection meets the
    footprint (widened by ``margin``), it is not clipped away, and in slice mode it
    reaches the slice plane."""
    u0, u1, v0, v1 = footprint.bounds
    clip_low, clip_high = clip_box(layer, meta)
    plane = slice_depth(layer, meta)

    def test(box: Box) -> bool:
        low, high = np.array(box[0]), np.array(box[1])
        if np.any(high < clip_low - margin) or np.any(low > clip_high + margin):
            return False
        corners = np.array([[(low, high)[(n >> a) & 1][a] for a in range(3)] for n in range(8)])
        u, v, depth = camera.project(corners)
        if u.max() < u0 - margin or u.min() > u1 + margin:
            return False
        if v.max() < v0 - margin or v.min() > v1 + margin:
            return False
        return not (
            layer.mode == "slice" and (depth.max() < plane - margin or depth.min() > plane + margin)
        )

    return test


def plan_tile(
    store: VolumeStore,
    camera: Camera,
    footprint: Footprint,
    layer: VolumeLayer,
    budget: int,
) -> TilePlan:
    """The refined render of a tile: the finest affordable level and its bricks."""
    meta = store.meta
    selections: dict[int, Selection] = {}

    def voxels_at(level: int) -> int:
        margin = 2 * voxel_size(meta, level)
        test = visible_test(camera, footprint, layer, meta, margin)
        selections[level] = store.select(test, level)
        return selections[level].count * meta.voxels_at(level)

    level = finest_level(voxels_at, useful_level(meta, footprint.pixel_size), meta.levels, budget)
    if level not in selections:
        voxels_at(level)
    return _with_image_size(meta, footprint, level, selections[level])


def fallback_plan(meta: VolumeMeta, footprint: Footprint) -> TilePlan:
    """The instant render of a tile from the coarse whole volume kept in memory."""
    level = max(meta.fallback_level, useful_level(meta, footprint.pixel_size))
    return _with_image_size(meta, footprint, min(level, meta.fallback_level), None)


def _with_image_size(
    meta: VolumeMeta, footprint: Footprint, level: int, selection: Selection | None
) -> TilePlan:
    scale = max(1, int(voxel_size(meta, level) / footprint.pixel_size))
    w, h = footprint.pixels
    return TilePlan(level, selection, scale, (-(-w // scale), -(-h // scale)))


def clip_box(layer: VolumeLayer, meta: VolumeMeta) -> tuple[Vector, Vector]:
    extent = np.array(meta.extent)
    return (
        np.array([c[0] for c in layer.clip]) * extent,
        np.array([c[1] for c in layer.clip]) * extent,
    )


def slice_depth(layer: VolumeLayer, meta: VolumeMeta) -> float:
    """The slice plane's distance from the centre along the view, mm."""
    return layer.slice * math.hypot(*meta.extent) / 2


@dataclass(frozen=True)
class Voxels:
    """Voxels at one level in memory, as float32 wrapped in one voxel of background,
    with the level index of the first unwrapped corner.

    The store keeps the last few for the next renders of the same bricks (a turned
    view often needs them all again), with what sampling derives from them.
    """

    wrapped: npt.NDArray[Any]
    origin: tuple[int, int, int]
    level: int
    _cells: dict[float, tuple[npt.NDArray[Any], npt.NDArray[Any]]] = field(
        default_factory=dict, compare=False, repr=False
    )

    @classmethod
    def wrap(
        cls, values: npt.NDArray[Any], origin: tuple[int, int, int], level: int, background: int
    ) -> Voxels:
        return cls(np.pad(values.astype(np.float32), 1, constant_values=background), origin, level)

    @classmethod
    def of(cls, store: VolumeStore, plan: TilePlan) -> Voxels:
        background = store.meta.background
        if plan.selection is None:
            return store.memo(
                ("fallback",),
                lambda: cls.wrap(store.fallback, (0, 0, 0), plan.level, background),
            )
        selection = plan.selection

        def assemble() -> Voxels:
            values, origin = store.assemble(selection)
            return cls.wrap(values, origin, selection.level, background)

        return store.memo(("bricks", selection.level, selection.rows.tobytes()), assemble)

    @property
    def values(self) -> npt.NDArray[Any]:
        """The voxels themselves (a view without the wrapping)."""
        return self.wrapped[1:-1, 1:-1, 1:-1]

    def cells(self, threshold: float) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
        """Per CELL^3 block of :attr:`wrapped`: whether it, or a voxel one beyond, reaches
        ``threshold``; and the same widened by one block in every direction."""
        if threshold not in self._cells:
            self._cells[threshold] = visible_cells(self.wrapped, threshold)
        return self._cells[threshold]


def visible_cells(
    values: npt.NDArray[Any], threshold: float
) -> tuple[npt.NDArray[Any], npt.NDArray[Any]]:
    """Per CELL^3 block of ``values``: whether it, or a voxel one beyond, reaches
    ``threshold`` (a sample's interpolation touches its voxel and the next along each
    axis); and the same widened by one block in every direction."""
    reach = values.copy()
    for axis in range(3):
        ahead: list[slice] = [slice(None)] * 3
        behind: list[slice] = [slice(None)] * 3
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        np.maximum(reach[tuple(behind)], reach[tuple(ahead)], out=reach[tuple(behind)])
    reach = np.pad(reach, [(0, -n % CELL) for n in reach.shape], mode="edge")
    x, y, z = (n // CELL for n in reach.shape)
    cells = reach.reshape(x, CELL, y, CELL, z, CELL).max(axis=5).max(axis=3).max(axis=1)
    visible = cells >= threshold
    near = np.pad(visible, 1)
    for axis in range(3):
        near = near | np.roll(near, 1, axis) | np.roll(near, -1, axis)
    return visible, near[1:-1, 1:-1, 1:-1]


def render(
    voxels: Voxels,
    meta: VolumeMeta,
    camera: Camera,
    footprint: Footprint,
    layer: VolumeLayer,
    scale: int,
) -> Image:
    """The tile's image, ``scale`` tile pixels per image pixel, RGB over black."""
    w, h = footprint.pixels
    columns, rows = -(-w // scale), -(-h // scale)
    xs = (np.arange(columns) + 0.5) * scale
    ys = (np.arange(rows) + 0.5) * scale
    px, py = np.meshgrid(xs, ys)
    a, b, c, d, e, f = footprint.to_plane
    u = (a * px + c * py + e).ravel()
    v = (b * px + d * py + f).ravel()
    starts = camera.centre + np.outer(u, camera.right) + np.outer(v, camera.down)
    sampler = _Sampler(voxels, meta, layer)
    if layer.mode == "slice":
        points = starts + slice_depth(layer, meta) * camera.forward
        inside = sampler.holds(points)
        rgb = sampler.colours(sampler.value(sampler.grid_offset(points)))[:, :3] * inside[:, None]
    else:
        step = voxel_size(meta, voxels.level)
        march = _March(sampler, starts, camera.forward, step)
        rgb = _maximum(sampler, march) if layer.mode == "mip" else _composite(sampler, march, step)
    image: Image = np.clip(np.rint(rgb * 255), 0, 255).astype(np.uint8)
    return image.reshape(rows, columns, 3)


def steps_inside(
    starts: Vector, stride: Vector, low: Vector, high: Vector
) -> tuple[Vector, Vector]:
    """Per ray the first and last ``k`` with ``start + k * stride`` in the box (half-open,
    ``low <= p < high`` on every axis, whichever way the ray runs); first > last when
    none."""
    with np.errstate(divide="ignore", invalid="ignore"):
        to_low = (low - starts) / stride
        to_high = (high - starts) / stride
        rising = stride > 0
        first = np.where(rising, np.ceil(to_low), np.floor(to_high) + 1)
        last = np.where(rising, np.ceil(to_high) - 1, np.floor(to_low))
    still = stride == 0
    inside = (starts >= low) & (starts < high)
    limit = np.iinfo(np.int32).max
    first = np.where(still, np.where(inside, -limit, limit), first)
    last = np.where(still, np.where(inside, limit, -limit), last)
    return first.max(axis=1).astype(np.int64), last.min(axis=1).astype(np.int64)


class _March:
    """Rays stepping through the held voxels together.

    Sample ``k`` of every ray lies at depth ``k * step``: one lattice for every tile
    and level, so neighbouring tiles sample alike. Each ray takes only the steps
    inside the kept box, trimmed further by a coarse pass to the stretch where it
    meets anything visible.
    """

    def __init__(self, sampler: _Sampler, starts: Vector, forward: Vector, step: float):
        self.grid0 = sampler.grid_offset(starts).astype(np.float32)
        self.delta = (step * forward / sampler.voxel).astype(np.float32)
        self.first, self.last = sampler.steps_inside(starts, step * forward)
        if not sampler.background_visible:  # beyond the held voxels nothing shows
            first, last = sampler.steps_inside(
                starts, step * forward, (sampler.held_low, sampler.held_high)
            )
            self.first, self.last = np.maximum(self.first, first), np.minimum(self.last, last)
        self.count = len(starts)

    def steps(
        self, every: int = 1, widen: int = 0
    ) -> Iterator[tuple[int, npt.NDArray[Any], npt.NDArray[Any]]]:
        """(k, the rays still marching, their grid positions), front to back; ``widen``
        extends every ray's range by that many steps at both ends."""
        first, last = self.first - widen, self.last + widen
        if not (first <= last).any():
            return
        for k in range(int(first.min()), int(last.max()) + 1, every):
            live = np.flatnonzero((first <= k) & (k <= last))
            if live.size:
                yield k, live, self.grid0[live] + np.float32(k) * self.delta

    def trim(self, near_visible: Callable[[npt.NDArray[Any]], npt.NDArray[Any]]) -> None:
        """Keep each ray's steps from just before its first to just after its last
        coarse sample near something visible (none: the ray is dropped).

        Coarse samples come every CELL steps, no further apart than a cell along any
        axis, and run a CELL beyond each ray's range, so every sample of the range has
        a coarse sample within half a cell: in a neighbouring cell, which
        ``near_visible`` (visibility dilated by a cell) sees.
        """
        hit_first = np.full(self.count, np.iinfo(np.int64).max)
        hit_last = np.full(self.count, np.iinfo(np.int64).min)
        for k, live, grid in self.steps(CELL, widen=CELL):
            hits = live[near_visible(grid)]
            hit_first[hits] = np.minimum(hit_first[hits], k)
            hit_last[hits] = k
        never = hit_first > hit_last
        self.first = np.maximum(self.first, hit_first - CELL)
        self.last = np.minimum(self.last, hit_last + CELL)
        self.first[never], self.last[never] = 1, 0

    def stop(self, rays: npt.NDArray[Any]) -> None:
        """Rays that need no more samples (already opaque)."""
        self.last[rays] = self.first[rays] - 1


def _composite(sampler: _Sampler, march: _March, step: float) -> npt.NDArray[Any]:
    """Front-to-back compositing; a ray stops once it is opaque."""
    colour = np.zeros((march.count, 3), dtype=np.float32)
    opacity = np.zeros(march.count, dtype=np.float32)
    table = sampler.table
    alpha_table = 1.0 - (1.0 - table[:, 3]) ** step  # opacity per mm -> per step
    march.trim(sampler.near_visible)
    for n, (_, marching, points) in enumerate(march.steps()):
        seen = sampler.maybe_visible(points)  # empty space adds nothing: skip it
        live = marching[seen]
        index = sampler.index(sampler.value(points[seen]))
        weight = (1.0 - opacity[live]) * alpha_table[index]
        colour[live] += weight[:, None] * table[index, :3]
        opacity[live] += weight
        if n % 8 == 7:
            march.stop(marching[opacity[marching] > OPAQUE])
    return colour


def _maximum(sampler: _Sampler, march: _March) -> npt.NDArray[Any]:
    """Maximum intensity along each ray, coloured by the transfer function."""
    best = np.full(march.count, -np.inf)
    for _, live, grid in march.steps():
        best[live] = np.maximum(best[live], sampler.value(grid))
    seen = np.isfinite(best)
    colours = sampler.colours(np.where(seen, best, sampler.value_range[0]))[:, :3]
    shown: npt.NDArray[Any] = colours * seen[:, None]
    return shown


def visible_threshold(table: npt.NDArray[Any], value_range: tuple[float, float]) -> float:
    """The smallest value a transfer table shows (inf: it shows nothing), halfway to
    the entry before, so interpolated samples that round onto it count."""
    visible_from = np.flatnonzero(table[:, 3] > 0)
    if not visible_from.size:
        return float(np.inf)
    low, high = value_range
    return float(low + (visible_from[0] - 0.5) * max(high - low, 1e-9) / (len(table) - 1))


def table_index(
    value: npt.NDArray[Any], value_range: tuple[float, float], entries: int
) -> npt.NDArray[Any]:
    """The transfer table row of each value (the nearest of ``entries`` rows)."""
    low, high = value_range
    scaled = (value - low) * ((entries - 1) / max(high - low, 1e-9))
    return np.clip(np.rint(scaled), 0, entries - 1).astype(np.int64)


def trilinear(
    flat: npt.NDArray[Any], strides: npt.NDArray[Any], top: npt.NDArray[Any], grid: Vector
) -> npt.NDArray[Any]:
    """Trilinear values at voxel coordinates ``grid`` (already clamped to the array) of
    the C-ordered array ``flat`` with ``strides``; ``top`` is its shape minus 2."""
    base = np.minimum(grid.astype(np.int64), top)
    frac = (grid - base).astype(np.float32)
    index = base @ strides
    fx, fy, fz = frac[:, 0], frac[:, 1], frac[:, 2]
    sx, sy, sz = (int(s) for s in strides)
    c00 = flat[index] + (flat[index + sz] - flat[index]) * fz
    c01 = flat[index + sy] + (flat[index + sy + sz] - flat[index + sy]) * fz
    c10 = flat[index + sx] + (flat[index + sx + sz] - flat[index + sx]) * fz
    c11 = flat[index + sx + sy] + (flat[index + sx + sy + sz] - flat[index + sx + sy]) * fz
    c0 = c00 + (c01 - c00) * fy
    c1 = c10 + (c11 - c10) * fy
    value: npt.NDArray[Any] = c0 + (c1 - c0) * fx
    return value


class _Sampler:
    """Trilinear samples of held voxels at world positions, and their colours.

    The held voxels are wrapped in one voxel of background: a sample beside the held
    bricks interpolates with the empty space there, as it would in the whole volume.
    At the volume's own faces samples clamp to the edge voxels instead.
    """

    def __init__(self, voxels: Voxels, meta: VolumeMeta, layer: VolumeLayer) -> None:
        self.values: npt.NDArray[Any] = voxels.wrapped
        self.flat: npt.NDArray[Any] = self.values.ravel()
        ny, nz = self.values.shape[1], self.values.shape[2]
        self.strides: npt.NDArray[Any] = np.array([ny * nz, nz, 1])
        # the padded array's first corner, in level voxels
        self.origin: npt.NDArray[Any] = np.array(voxels.origin, dtype=np.float64) - 1
        self.voxel: npt.NDArray[Any] = np.array(meta.spacing) * (1 << voxels.level)
        self.top: npt.NDArray[Any] = np.array(self.values.shape) - 2
        level_last = np.array(meta.level_shape(voxels.level), dtype=np.float64) - 1
        edge = np.array(self.values.shape) - 1
        self.clamp_low: npt.NDArray[Any] = np.maximum(-self.origin, 0).astype(np.float32)
        self.clamp_high: npt.NDArray[Any] = np.minimum(level_last - self.origin, edge).astype(
            np.float32
        )
        # Samples run through the whole clip box: beyond the held voxels (and their
        # background wrapping) they clamp onto that wrapping and read background.
        self.low_corner, self.high_corner = clip_box(layer, meta)
        self.value_range = meta.value_range
        self.table: npt.NDArray[Any] = lookup_table(layer.transfer)
        self.visible, self.near = voxels.cells(visible_threshold(self.table, meta.value_range))
        self.last_cell = np.array(self.visible.shape) - 1
        # beyond this box (the held voxels and their wrapping) samples read background
        self.held_low = self.origin * self.voxel
        self.held_high = (self.origin + np.array(self.values.shape)) * self.voxel
        self.background_visible = bool(self.table[self.index(np.array(meta.background)), 3] > 0)

    def steps_inside(
        self, starts: Vector, stride: Vector, box: tuple[Vector, Vector] | None = None
    ) -> tuple[Vector, Vector]:
        """Per ray the steps inside ``box`` (the kept box by default), see
        :func:`steps_inside`."""
        low, high = box if box is not None else (self.low_corner, self.high_corner)
        return steps_inside(starts, stride, low, high)

    def holds_axis(self, points: Vector) -> npt.NDArray[Any]:
        return (points >= self.low_corner) & (points < self.high_corner)

    def holds(self, points: Vector) -> npt.NDArray[Any]:
        """Whether world points lie in the kept box."""
        held: npt.NDArray[Any] = np.all(self.holds_axis(points), axis=1)
        return held

    def grid_offset(self, points: Vector) -> Vector:
        """World points as (unclamped) coordinates in the padded voxel array."""
        return np.asarray(points / self.voxel - 0.5 - self.origin)

    def value(self, grid: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """Trilinear values at array coordinates."""
        grid = np.clip(grid, self.clamp_low, self.clamp_high)
        return trilinear(self.flat, self.strides, self.top, grid)

    def maybe_visible(self, grid: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """False where every voxel a sample's interpolation touches is transparent."""
        return np.asarray(self.visible[self._cell_of(grid)])

    def near_visible(self, grid: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """:meth:`maybe_visible` widened by one cell in every direction."""
        return np.asarray(self.near[self._cell_of(grid)])

    def _cell_of(self, grid: npt.NDArray[Any]) -> tuple[npt.NDArray[Any], ...]:
        cell = np.clip(grid.astype(np.int32) // CELL, 0, self.last_cell)
        return cell[:, 0], cell[:, 1], cell[:, 2]

    def index(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        return table_index(value, self.value_range, len(self.table))

    def colours(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        return np.asarray(self.table[self.index(value)])
