"""Where the brain atlas puts its pins: on regions the viewer can actually see.

The wall shows the MNI template with the volume renderer, so what a point of the
picture shows is decided the way the renderer decides it. One ray is cast per
millimetre of the image plane across the projection of the layer's clip box,
sampled at the renderer's lattice (depth ``k`` mm from the plane through the
volume's centre), trilinearly, and composited with the layer's transfer function
(opacity per mm); the picture there shows what the ray has reached when its
accumulated opacity first crosses :data:`SEEN`. The atlas label of that voxel names
the region (on the white matter just under the cortex, which the atlas leaves
unlabelled, the first label up to :data:`LOOKAHEAD` mm further along the ray). In
slice mode the picture is the slice plane, and the label is the one on it.

A region is visible when its labels cover at least :data:`MIN_AREA` of the plane; its
pin goes on the visible pixel farthest from the edge of that area (ties: nearest its
centroid). All of this depends only on the orientation (yaw, pitch and the layer),
not on zoom and centre, which only move the plane on the scene: :class:`PinCache`
keeps results per orientation, and :func:`scene_pins` places them on the scene with
the inverse of the renderer's own scene -> plane map.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import numpy.typing as npt

from wall_client.layout import Wall, apply_affine, invert_affine
from webapp.apps.brain_atlas.content import ATLAS_DIR, ContentError, Region
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.build import DEFAULT_BRICK
from webapp.volume.render import (
    CELL,
    Camera,
    clip_box,
    scene_to_plane,
    slice_depth,
    steps_inside,
    table_index,
    trilinear,
    visible_cells,
    visible_threshold,
)
from webapp.volume.store import VolumeMeta
from webapp.volume.transfer import lookup_table

TEMPLATE_FILE = "mni_icbm152_t1_tal_nlin_sym_09a.nii.gz"
LABELS_FILE = "atlas-desikankilliany.nii.gz"
VOLUME = "mni152"  # the store built from TEMPLATE_FILE

MIN_AREA = 25.0  # mm² of the image plane a region must show to get a pin
PIXEL = 1.0  # mm between rays on the image plane
STEP = 1.0  # mm between samples along a ray (the renderer's level 0 on this template)
SEEN = 0.5  # the accumulated opacity at which a ray shows what it has reached
LOOKAHEAD = 3.0  # mm further along the ray to look for a label when that voxel has none
LOOKAHEAD_STEP = 0.5
CHUNK = 8  # samples per ray and pass
CACHED = 64  # orientations a PinCache keeps

Array = npt.NDArray[Any]


@dataclass(frozen=True)
class PlanePin:
    """A region's pin on the image plane: (u, v) in world mm as the renderer's plane
    has them, the depth of the labelled point along the view (so the 3-D point is
    ``centre + u * right + v * down + depth * forward``), and the region's visible
    area in mm²."""

    u: float
    v: float
    depth: float
    area: float


@dataclass(frozen=True)
class Orientation:
    """What decides which regions show, and where on the plane: the view's yaw and
    pitch and the volume layer (zoom and centre only move the plane on the scene).

    Orientations that give the same picture compare and hash alike: the yaw is taken
    modulo 360, the layer's volume name does not count, nor its slice offset outside
    slice mode.
    """

    yaw: float
    pitch: float
    layer: VolumeLayer = field(compare=False)
    key: tuple[Hashable, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "yaw", float(self.yaw) % 360.0)
        object.__setattr__(self, "pitch", float(self.pitch))
        layer = self.layer
        offset = layer.slice if layer.mode == "slice" else 0.0
        object.__setattr__(self, "key", (layer.mode, layer.transfer, layer.clip, offset))

    @classmethod
    def of(cls, view: View, layer: VolumeLayer) -> Orientation:
        return cls(view.yaw, view.pitch, layer)


class AtlasVolumes:
    """The template and the atlas labels on the template's voxel grid, in memory.

    Loading reads both files (a second or so): the owner does it once, when first
    needed. ``meta`` is the template's geometry and value range as a volume store
    built from it reports them (the renderer's camera, clip box and transfer
    lookups use those).
    """

    def __init__(self, template: Array, labels: Array, meta: VolumeMeta) -> None:
        if template.shape != labels.shape or template.shape != meta.shape:
            raise ValueError("the template, labels and meta must share one grid")
        self.template: Array = np.ascontiguousarray(template, dtype=np.float32)
        self.labels: Array = np.ascontiguousarray(labels, dtype=np.uint8)
        self.meta = meta
        self.flat: Array = self.template.ravel()
        _, ny, nz = self.template.shape
        self.strides: Array = np.array([ny * nz, nz, 1], dtype=np.int64)
        self.last: Array = np.array(self.template.shape, dtype=np.float64) - 1
        self.top: Array = np.array(self.template.shape, dtype=np.int64) - 2
        self.spacing: Array = np.array(meta.spacing, dtype=np.float64)
        self._cells: dict[float, Array] = {}
        self._lock = threading.Lock()

    @classmethod
    def load(cls, directory: Path = ATLAS_DIR, meta: VolumeMeta | None = None) -> AtlasVolumes:
        """Read the template and the labels from ``directory``; ``meta`` (the store's)
        is checked against the template when given. ContentError when the files are
        missing, unreadable or do not line up."""
        import nibabel  # only this needs it, and only when the pins are first asked for

        images: list[Any] = []
        for name in (TEMPLATE_FILE, LABELS_FILE):
            try:
                images.append(nibabel.load(directory / name))
            except FileNotFoundError:
                raise ContentError([f"{name}: missing"]) from None
            except Exception as error:  # nibabel raises many kinds on a bad file
                raise ContentError([f"{name}: cannot read it as a volume ({error})"]) from error
        template_image, labels_image = images
        template = np.asarray(template_image.dataobj)
        labels = np.asarray(labels_image.dataobj)
        if template.ndim != 3 or labels.ndim != 3:
            raise ContentError([f"{TEMPLATE_FILE}, {LABELS_FILE}: 3-D volumes are needed"])
        offset = _voxel_offset(template_image.affine, labels_image.affine)
        if offset is None:
            raise ContentError(
                [f"{LABELS_FILE}: its voxels are not the template's voxels shifted by whole voxels"]
            )
        embedded = np.zeros(template.shape, dtype=np.uint8)
        low = np.maximum(offset, 0)
        high = np.minimum(offset + np.array(labels.shape), template.shape)
        if np.any(high <= low):
            raise ContentError([f"{LABELS_FILE}: it does not overlap the template"])
        inner = tuple(slice(a, b) for a, b in zip(low - offset, high - offset, strict=True))
        embedded[tuple(slice(a, b) for a, b in zip(low, high, strict=True))] = labels[inner]
        spacing = tuple(float(z) for z in template_image.header.get_zooms()[:3])
        own = _template_meta(template, (spacing[0], spacing[1], spacing[2]))
        if meta is not None and (
            meta.shape != own.shape
            or not np.allclose(meta.spacing, own.spacing)
            or meta.value_range != own.value_range
            or (meta.scale, meta.offset) != (1.0, 0.0)
        ):
            raise ContentError(
                [f"volume store {meta.name!r}: not built from {TEMPLATE_FILE} (rebuild it)"]
            )
        return cls(template, embedded, meta or own)

    def cells(self, threshold: float) -> Array:
        """Per CELL^3 block: whether a sample there may reach ``threshold`` (some voxel
        its interpolation touches does), widened by one block every way."""
        with self._lock:
            found = self._cells.get(threshold)
        if found is None:
            found = visible_cells(self.template, threshold)[1]
            with self._lock:
                self._cells[threshold] = found
        return found

    def grid(self, points: Array) -> Array:
        """World points as voxel coordinates (voxel ``i`` has its centre at
        ``(i + 0.5) * spacing``, as in the store), clamped to the volume."""
        return np.clip(points / self.spacing - 0.5, 0.0, self.last)

    def sample(self, points: Array) -> Array:
        """Trilinear template values at world points (clamped at the faces)."""
        return trilinear(self.flat, self.strides, self.top, self.grid(points))

    def label(self, points: Array) -> Array:
        """The atlas label of the voxel holding each world point (0 outside)."""
        index = np.floor(points / self.spacing).astype(np.int64)
        shape = np.array(self.labels.shape)
        inside = np.all((index >= 0) & (index < shape), axis=-1)
        index = np.clip(index, 0, shape - 1)
        found: Array = self.labels[index[..., 0], index[..., 1], index[..., 2]]
        return np.where(inside, found, 0)


def _voxel_offset(template_affine: Array, labels_affine: Array) -> Array | None:
    """The template voxel of the labels' voxel (0, 0, 0), when the labels' grid is the
    template's shifted by whole voxels (None otherwise)."""
    to_template = np.linalg.inv(template_affine) @ labels_affine
    if not np.allclose(to_template[:3, :3], np.eye(3), atol=1e-4):
        return None
    shift = to_template[:3, 3]
    if not np.allclose(shift, np.rint(shift), atol=1e-3):
        return None
    return np.rint(shift).astype(np.int64)


def _template_meta(template: Array, spacing: tuple[float, float, float]) -> VolumeMeta:
    """What a store built from the template says about its geometry and values (the
    brick layout filled in as the build would choose it; nothing here reads it)."""
    shape = (int(template.shape[0]), int(template.shape[1]), int(template.shape[2]))
    grid = tuple(-(-n // DEFAULT_BRICK) for n in shape)
    low, high = float(template.min()), float(template.max())
    return VolumeMeta(
        name=VOLUME,
        source=TEMPLATE_FILE,
        shape=shape,
        spacing=spacing,
        brick=DEFAULT_BRICK,
        levels=int(math.log2(DEFAULT_BRICK)),
        grid=(grid[0], grid[1], grid[2]),
        depth=math.ceil(math.log2(max(grid))) if max(grid) > 1 else 0,
        dtype="int16",
        value_range=(low, high),
        background=int(low),
        fallback_level=0,
        stored_bricks=0,
        empty_bricks=0,
    )


@dataclass(frozen=True)
class _Rays:
    """The rays of one orientation: one per plane pixel, row-major over (v, u)."""

    camera: Camera
    us: Array  # pixel centres along u
    vs: Array  # and along v
    starts: Array  # world points on the plane, (n, 3)
    low: Array  # the clip box
    high: Array

    @classmethod
    def across(cls, volumes: AtlasVolumes, orientation: Orientation) -> _Rays:
        meta = volumes.meta
        camera = Camera.looking(meta, orientation.yaw, orientation.pitch)
        low, high = clip_box(orientation.layer, meta)
        corners = np.array([[(low, high)[(n >> a) & 1][a] for a in range(3)] for n in range(8)])
        u, v, _ = camera.project(corners)
        us = np.arange(math.floor(u.min() / PIXEL), math.ceil(u.max() / PIXEL)) * PIXEL
        vs = np.arange(math.floor(v.min() / PIXEL), math.ceil(v.max() / PIXEL)) * PIXEL
        us, vs = us + PIXEL / 2, vs + PIXEL / 2
        uu, vv = np.meshgrid(us, vs)
        starts = camera.centre + np.outer(uu.ravel(), camera.right)
        starts += np.outer(vv.ravel(), camera.down)
        return cls(camera, us, vs, starts, low, high)

    def holds(self, points: Array) -> Array:
        """Whether world points lie in the clip box (half-open, as the renderer)."""
        held: Array = np.all((points >= self.low) & (points < self.high), axis=-1)
        return held


def _seen_points(volumes: AtlasVolumes, rays: _Rays, layer: VolumeLayer) -> tuple[Array, Array]:
    """Per ray whether its opacity crosses SEEN, and the sample index ``k`` where it
    first does (composite and mip: the same opacity, as the renderer accumulates it)."""
    meta = volumes.meta
    forward = rays.camera.forward
    stride = STEP * forward
    count = len(rays.starts)
    first, last = steps_inside(rays.starts, stride, rays.low, rays.high)
    table = lookup_table(layer.transfer)
    alpha_table = 1.0 - (1.0 - table[:, 3].astype(np.float64)) ** STEP
    crossed = np.zeros(count, dtype=bool)
    at = np.zeros(count, dtype=np.int64)
    threshold = visible_threshold(table, meta.value_range)
    if threshold == np.inf:
        return crossed, at
    near = volumes.cells(threshold)
    last_cell = np.array(near.shape) - 1

    # Coarse: every CELL steps, the first sample near anything visible (the samples
    # between lie within half a cell of one, and ``near`` is widened by a cell).
    start = np.full(count, np.iinfo(np.int64).max)
    live = np.flatnonzero(first <= last)
    k = first[live] - CELL
    while live.size:
        points = rays.starts[live] + (k * STEP)[:, None] * forward
        cell = np.clip(volumes.grid(points).astype(np.int64) // CELL, 0, last_cell)
        hit = near[cell[:, 0], cell[:, 1], cell[:, 2]]
        start[live[hit]] = np.maximum(first[live[hit]], k[hit] - CELL)
        going = ~hit & (k <= last[live])  # coarse samples run a CELL past the range
        live, k = live[going], k[going] + CELL

    # Fine: CHUNK samples per pass; a ray leaves once it crosses or leaves the box.
    transmit = np.ones(count)
    live = np.flatnonzero(start <= last)
    k = start[live]
    offsets = np.arange(CHUNK)
    while live.size:
        ks = k[:, None] + offsets
        valid = ks <= last[live, None]
        points = rays.starts[live, None, :] + (ks * STEP)[..., None] * forward
        values = volumes.sample(points.reshape(-1, 3)).reshape(ks.shape)
        index = table_index(values, meta.value_range, len(table))
        alpha = np.where(valid, alpha_table[index], 0.0)
        through = transmit[live, None] * np.cumprod(1.0 - alpha, axis=1)
        over = through <= 1.0 - SEEN
        done = over.any(axis=1)
        crossed[live[done]] = True
        at[live[done]] = ks[done, over[done].argmax(axis=1)]
        transmit[live] = through[:, -1]
        going = ~done & (ks[:, -1] < last[live])
        live, k = live[going], k[going] + CHUNK
    return crossed, at


def _label_image(volumes: AtlasVolumes, rays: _Rays, layer: VolumeLayer) -> tuple[Array, Array]:
    """Per ray the label the picture shows there (0: none) and its depth."""
    forward = rays.camera.forward
    meta = volumes.meta
    if layer.mode == "slice":
        depth = np.full(len(rays.starts), slice_depth(layer, meta))
        points = rays.starts + depth[:, None] * forward
        labels = np.where(rays.holds(points), volumes.label(points), 0)
        return labels, depth
    crossed, at = _seen_points(volumes, rays, layer)
    depth = at * STEP
    labels = np.zeros(len(rays.starts), dtype=np.uint8)
    hit = np.flatnonzero(crossed)
    points = rays.starts[hit] + depth[hit, None] * forward
    labels[hit] = volumes.label(points)
    blank = hit[labels[hit] == 0]
    ahead = np.arange(1, round(LOOKAHEAD / LOOKAHEAD_STEP) + 1) * LOOKAHEAD_STEP
    further = depth[blank, None] + ahead  # (n, steps)
    points = rays.starts[blank, None, :] + further[..., None] * forward
    found = np.where(rays.holds(points), volumes.label(points), 0)
    some = found.any(axis=1)
    which = (found != 0).argmax(axis=1)  # the first label along the ray
    rows = np.flatnonzero(some)
    labels[blank[rows]] = found[rows, which[rows]]
    depth[blank[rows]] = further[rows, which[rows]]
    return labels, depth


@dataclass(frozen=True)
class Picture:
    """What the picture shows of the atlas for one orientation: per plane pixel (rows
    along v, columns along u, centres at ``vs`` and ``us``) the label seen there (0:
    none) and the depth along the view where it was found."""

    camera: Camera
    us: Array
    vs: Array
    labels: Array
    depth: Array


def picture(volumes: AtlasVolumes, orientation: Orientation) -> Picture:
    """Cast the orientation's rays (or cut its slice) and label what each shows."""
    rays = _Rays.across(volumes, orientation)
    labels, depth = _label_image(volumes, rays, orientation.layer)
    shape = (len(rays.vs), len(rays.us))
    return Picture(rays.camera, rays.us, rays.vs, labels.reshape(shape), depth.reshape(shape))


def visible_regions(
    volumes: AtlasVolumes, regions: Sequence[Region], orientation: Orientation
) -> dict[str, PlanePin]:
    """The regions the viewer can see in ``orientation`` (at least MIN_AREA of the
    picture), each with its pin on the image plane."""
    shown = picture(volumes, orientation)
    pins: dict[str, PlanePin] = {}
    for region in regions:
        mask = np.isin(shown.labels, region.labels)
        area = float(mask.sum()) * PIXEL * PIXEL
        if area < MIN_AREA:
            continue
        row, column = _deepest(mask)
        pins[region.id] = PlanePin(
            u=float(shown.us[column]),
            v=float(shown.vs[row]),
            depth=float(shown.depth[row, column]),
            area=area,
        )
    return pins


def _deepest(mask: Array) -> tuple[int, int]:
    """The pixel of ``mask`` farthest from its edge (by repeated erosion, alternately
    by a cross and a square: an octagonal distance); ties go to the one nearest the
    mask's centroid."""
    inner = np.pad(mask, 1)
    deepest = inner
    n = 0
    while inner.any():
        deepest = inner
        core = inner[1:-1, 1:-1] & inner[:-2, 1:-1] & inner[2:, 1:-1]
        core &= inner[1:-1, :-2] & inner[1:-1, 2:]
        if n % 2:
            core &= inner[:-2, :-2] & inner[:-2, 2:] & inner[2:, :-2] & inner[2:, 2:]
        inner = np.pad(core, 1)
        n += 1
    candidates = np.argwhere(deepest[1:-1, 1:-1])
    centroid = np.argwhere(mask).mean(axis=0)
    best = candidates[np.argmin(((candidates - centroid) ** 2).sum(axis=1))]
    return int(best[0]), int(best[1])


def plane_point(camera: Camera, u: float, v: float, depth: float) -> Array:
    """The world point at (u, v) on the image plane and ``depth`` along the view."""
    point: Array = camera.centre + u * camera.right + v * camera.down + depth * camera.forward
    return point


def scene_pins(
    plane_pins: Mapping[str, PlanePin],
    wall: Wall,
    view: View,
    meta: VolumeMeta,
) -> dict[str, tuple[float, float]]:
    """The pins on the scene (mm) for ``view`` of the picture framed on ``wall``'s
    stage, through the inverse of the renderer's scene -> plane map. Pins off the wall
    are left out, and so are pins under a designated screen (a zoomed picture reaches
    beyond the stage): a panel or a publication covers them there."""
    to_scene = invert_affine(scene_to_plane(view, wall.stage, meta))
    width, height = wall.width, wall.height
    panels = [wall.viewport(d).scene_rect for d in wall.designated()]
    placed: dict[str, tuple[float, float]] = {}
    for region_id, pin in plane_pins.items():
        x, y = apply_affine(to_scene, pin.u, pin.v)
        on_wall = 0.0 <= x <= width and 0.0 <= y <= height
        if on_wall and not any(panel.contains((x, y)) for panel in panels):
            placed[region_id] = (x, y)
    return placed


class _Pending:
    """A result being computed by one thread, which the others wait for."""

    def __init__(self) -> None:
        self.done = threading.Event()
        self.value: Mapping[str, PlanePin] | None = None
        self.error: BaseException | None = None


class PinCache:
    """The visible regions per orientation and region list, computed once each.

    Thread-safe: the first thread to ask for a key computes it while others asking for
    the same key wait for that result (other keys go on in parallel). Keeps the last
    ``size`` keys. Results are read-only mappings; a hit returns the same object. A
    cache serves one :class:`AtlasVolumes`: given another, it starts afresh.
    """

    def __init__(self, *, size: int = CACHED) -> None:
        self._size = size
        self._lock = threading.Lock()
        self._volumes: AtlasVolumes | None = None
        self._entries: OrderedDict[Hashable, _Pending] = OrderedDict()

    def get(
        self,
        volumes: AtlasVolumes,
        regions: Sequence[Region],
        view: View,
        layer: VolumeLayer,
    ) -> Mapping[str, PlanePin]:
        """The regions of ``regions`` visible with ``view`` and ``layer``, with their
        pins on the image plane (see :func:`visible_regions`)."""
        orientation = Orientation.of(view, layer)
        key = (orientation, tuple((r.id, tuple(r.labels)) for r in regions))
        with self._lock:
            if self._volumes is not volumes:
                self._volumes = volumes
                self._entries.clear()
            entry = self._entries.get(key)
            owner = entry is None
            if entry is None:
                entry = self._entries[key] = _Pending()
                while len(self._entries) > self._size:
                    self._entries.popitem(last=False)
            else:
                self._entries.move_to_end(key)
        if owner:
            try:
                entry.value = MappingProxyType(visible_regions(volumes, regions, orientation))
            except BaseException as error:
                entry.error = error
                with self._lock:
                    if self._entries.get(key) is entry:
                        del self._entries[key]
                raise
            finally:
                entry.done.set()
        else:
            entry.done.wait()
        if entry.error is not None:
            raise entry.error
        assert entry.value is not None
        return entry.value

    def __len__(self) -> int:
        with self._lock:
            return len(self._entries)
