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
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from wall_client.layout import Affine, Viewport, apply_affine, compose_affine, invert_affine
from webapp.volume.layer import VolumeLayer, lookup_table
from webapp.volume.store import Box, Selection, VolumeMeta, VolumeStore
from webapp.wall_state import View

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


@dataclass(frozen=True)
class Footprint:
    """A tile on the image plane: its pixel (x, y) -> plane (u, v) map and size."""

    to_plane: Affine
    pixels: tuple[int, int]

    @classmethod
    def of(
        cls, viewport: Viewport, view: View, scene_size: tuple[float, float], meta: VolumeMeta
    ) -> Footprint:
        width, height = scene_size
        k = max(meta.extent) / min(width, height)  # world mm per scene mm at zoom 1
        zoom = view.zoom
        cx, cy = view.center
        scene_to_plane: Affine = (
            k / zoom,
            0.0,
            0.0,
            k / zoom,
            k * ((cx - 0.5) * width - width / (2 * zoom)),
            k * ((cy - 0.5) * height - height / (2 * zoom)),
        )
        to_plane = compose_affine(scene_to_plane, invert_affine(viewport.to_pixels))
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
    """Voxels at one level in memory, with the level index of their first corner."""

    values: npt.NDArray[Any]
    origin: tuple[int, int, int]
    level: int

    @classmethod
    def of(cls, store: VolumeStore, plan: TilePlan) -> Voxels:
        if plan.selection is None:
            return cls(store.fallback.astype(np.int32, copy=False), (0, 0, 0), plan.level)
        values, origin = store.assemble(plan.selection)
        return cls(values, origin, plan.level)


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


class _March:
    """Rays stepping through the held voxels together.

    Sample ``k`` of every ray lies at depth ``k * step``: one lattice for every tile
    and level, so neighbouring tiles sample alike. Each ray takes only the steps
    inside the kept box, trimmed further by a coarse pass to the stretch where it
    meets anything visible.
    """

    def __init__(self, sampler: _Sampler, starts: Vector, forward: Vector, step: float):
        self.grid0 = sampler.grid_offset(starts)
        self.delta = step * forward / sampler.voxel
        enter, leave = sampler.crossing(starts, forward)
        with np.errstate(invalid="ignore"):
            first = np.ceil(enter / step)
            last = np.ceil(leave / step) - 1  # the box is half-open
        missed = ~(first <= last)
        first[missed], last[missed] = 1, 0
        self.first, self.last = first.astype(np.int64), last.astype(np.int64)
        self.count = len(starts)

    def steps(self, every: int = 1) -> Iterator[tuple[int, npt.NDArray[Any], npt.NDArray[Any]]]:
        """(k, the rays still marching, their grid positions), front to back."""
        if not (self.first <= self.last).any():
            return
        for k in range(int(self.first.min()), int(self.last.max()) + 1, every):
            live = np.flatnonzero((self.first <= k) & (k <= self.last))
            if live.size:
                yield k, live, (self.grid0[live] + k * self.delta).astype(np.float32)

    def trim(self, near_visible: Callable[[npt.NDArray[Any]], npt.NDArray[Any]]) -> None:
        """Keep each ray's steps from just before its first to just after its last
        coarse sample near something visible (none: the ray is dropped).

        Coarse samples come every CELL steps, no further apart than a cell along any
        axis, so a sample in a visible cell has a coarse sample within half that in a
        neighbouring cell, which ``near_visible`` (visibility dilated by a cell) sees.
        """
        hit_first = np.full(self.count, np.iinfo(np.int64).max)
        hit_last = np.full(self.count, np.iinfo(np.int64).min)
        for k, live, grid in self.steps(CELL):
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
    colours = sampler.colours(np.where(seen, best, sampler.low))[:, :3]
    shown: npt.NDArray[Any] = colours * seen[:, None]
    return shown


class _Sampler:
    """Trilinear samples of held voxels at world positions, and their colours.

    The held voxels are wrapped in one voxel of background: a sample beside the held
    bricks interpolates with the empty space there, as it would in the whole volume.
    At the volume's own faces samples clamp to the edge voxels instead.
    """

    def __init__(self, voxels: Voxels, meta: VolumeMeta, layer: VolumeLayer) -> None:
        held = voxels.values
        padded = np.pad(held.astype(np.float32), 1, constant_values=meta.background)
        self.values: npt.NDArray[Any] = padded
        self.flat: npt.NDArray[Any] = self.values.ravel()
        ny, nz = self.values.shape[1], self.values.shape[2]
        self.strides: npt.NDArray[Any] = np.array([ny * nz, nz, 1])
        # the padded array's first corner, in level voxels
        self.origin: npt.NDArray[Any] = np.array(voxels.origin, dtype=np.float64) - 1
        self.voxel: npt.NDArray[Any] = np.array(meta.spacing) * (1 << voxels.level)
        self.top: npt.NDArray[Any] = np.array(self.values.shape) - 2
        level_last = np.array(meta.level_shape(voxels.level), dtype=np.float64) - 1
        self.clamp_low: npt.NDArray[Any] = (-self.origin).astype(np.float32)
        self.clamp_high: npt.NDArray[Any] = (level_last - self.origin).astype(np.float32)
        clip_low, clip_high = clip_box(layer, meta)
        held_low = (self.origin + 1) * self.voxel
        held_high = (self.origin + 1 + np.array(held.shape)) * self.voxel
        self.low_corner: npt.NDArray[Any] = np.maximum(clip_low, held_low)
        self.high_corner: npt.NDArray[Any] = np.minimum(clip_high, held_high)
        self.low, high = meta.value_range
        self.span = max(high - self.low, 1e-9)
        self.table: npt.NDArray[Any] = lookup_table(layer.transfer)
        self._cells: npt.NDArray[Any] | None = None
        self._near: npt.NDArray[Any] | None = None

    def crossing(self, starts: Vector, direction: Vector) -> tuple[Vector, Vector]:
        """Where each ray enters and leaves the kept box (slab method; NaN: misses)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            t_low = (self.low_corner - starts) / direction
            t_high = (self.high_corner - starts) / direction
        parallel = direction == 0
        within = self.holds_axis(starts)
        near = np.where(parallel, np.where(within, -np.inf, np.nan), np.minimum(t_low, t_high))
        far = np.where(parallel, np.where(within, np.inf, np.nan), np.maximum(t_low, t_high))
        return near.max(axis=1), far.min(axis=1)

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
        base = np.minimum(grid.astype(np.int64), self.top)
        frac = (grid - base).astype(np.float32)
        index = base @ self.strides
        fx, fy, fz = frac[:, 0], frac[:, 1], frac[:, 2]
        sx, sy, sz = self.strides
        flat = self.flat
        c00 = flat[index] + (flat[index + sz] - flat[index]) * fz
        c01 = flat[index + sy] + (flat[index + sy + sz] - flat[index + sy]) * fz
        c10 = flat[index + sx] + (flat[index + sx + sz] - flat[index + sx]) * fz
        c11 = flat[index + sx + sy] + (flat[index + sx + sy + sz] - flat[index + sx + sy]) * fz
        c0 = c00 + (c01 - c00) * fy
        c1 = c10 + (c11 - c10) * fy
        value: npt.NDArray[Any] = c0 + (c1 - c0) * fx
        return value

    def maybe_visible(self, grid: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """False where every voxel a sample's interpolation touches is transparent."""
        if self._cells is None:
            self._cells = self._visible_cells()
        return np.asarray(self._cells[self._cell_of(grid)])

    def near_visible(self, grid: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """:meth:`maybe_visible` widened by one cell in every direction."""
        if self._near is None:
            cells = self._cells if self._cells is not None else self._visible_cells()
            self._cells = cells
            near = np.pad(cells, 1)
            for axis in range(3):
                near = near | np.roll(near, 1, axis) | np.roll(near, -1, axis)
            self._near = near[1:-1, 1:-1, 1:-1]
        return np.asarray(self._near[self._cell_of(grid)])

    def _cell_of(self, grid: npt.NDArray[Any]) -> tuple[npt.NDArray[Any], ...]:
        clamped = np.clip(grid, self.clamp_low, self.clamp_high)
        cell = np.minimum(clamped.astype(np.int64), self.top) // CELL
        return cell[:, 0], cell[:, 1], cell[:, 2]

    def _visible_cells(self) -> npt.NDArray[Any]:
        """Per CELL^3 block: does it, or a voxel one beyond, reach a visible value."""
        reach = self.values.copy()
        for axis in range(3):
            ahead: list[slice] = [slice(None)] * 3
            behind: list[slice] = [slice(None)] * 3
            ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
            np.maximum(reach[tuple(behind)], reach[tuple(ahead)], out=reach[tuple(behind)])
        reach = np.pad(reach, [(0, -n % CELL) for n in reach.shape], mode="edge")
        x, y, z = (n // CELL for n in reach.shape)
        maxima = reach.reshape(x, CELL, y, CELL, z, CELL).max(axis=5).max(axis=3).max(axis=1)
        visible_from = np.flatnonzero(self.table[:, 3] > 0)
        if visible_from.size == 0:
            return np.zeros(maxima.shape, dtype=bool)
        threshold = self.low + (visible_from[0] - 0.5) * self.span / (len(self.table) - 1)
        visible: npt.NDArray[Any] = maxima >= threshold
        return visible

    def index(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        scaled = (value - self.low) * ((len(self.table) - 1) / self.span)
        return np.clip(np.rint(scaled), 0, len(self.table) - 1).astype(np.int64)

    def colours(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        return np.asarray(self.table[self.index(value)])
