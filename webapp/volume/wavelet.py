"""Lossless integer 3D Haar wavelets by lifting, stored coarse first.

One level halves a cubic block along each axis in turn: every pair ``(a, b)`` becomes
the difference ``d = b - a`` and the sum ``s = a + floor(d / 2)``, which is
``floor((a + b) / 2)``. Integers in, integers out, exactly invertible (the
S-transform). After ``levels`` levels a block of side ``n`` is a coarse block of
side ``n >> levels`` and seven detail bands per level.

The stream puts the coarse block first, then the details from the coarsest level to
the finest. A prefix of ``(n >> level) ** 3`` values is therefore everything needed
to rebuild the block at ``level`` (0 = full detail): reading less of the file gives
less detail, which is how a tile with a small budget reads only what it shows.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

Block = npt.NDArray[Any]


def prefix_length(size: int, level: int) -> int:
    """How many leading stream values rebuild a ``size``-sided block at ``level``."""
    return int(size >> level) ** 3


def forward(block: Block, levels: int, dtype: npt.DTypeLike = np.int32) -> Block:
    """The coefficient stream (1-D, coarse first) of a cubic ``block``."""
    size = block.shape[0]
    if block.shape != (size,) * 3 or size % (1 << levels):
        raise ValueError(f"a cube whose side divides by 2**{levels} is needed, not {block.shape}")
    coarse = block.astype(np.int32)
    finer_first: list[list[Block]] = []
    for _ in range(levels):
        bands = _split(coarse)
        coarse = bands[0]
        finer_first.append(bands[1:])
    parts = [coarse.ravel()] + [b.ravel() for bands in reversed(finer_first) for b in bands]
    return np.concatenate(parts).astype(dtype, copy=False)


def inverse(stream: Block, size: int, levels: int, level: int = 0) -> Block:
    """The block at ``level`` rebuilt from (at least) the first
    ``prefix_length(size, level)`` values of its stream."""
    if not 0 <= level <= levels:
        raise ValueError(f"level {level} is not between 0 and {levels}")
    side = size >> levels
    position = side**3
    coarse = np.asarray(stream[:position], dtype=np.int32).reshape(side, side, side)
    for _ in range(levels - level):
        count = side**3
        bands = [
            np.asarray(
                stream[position + i * count : position + (i + 1) * count], dtype=np.int32
            ).reshape(side, side, side)
            for i in range(7)
        ]
        position += 7 * count
        coarse = _merge([coarse, *bands])
        side *= 2
    return coarse


def downsample(volume: Block, levels: int) -> Block:
    """The plain definition of a coarser level: pairwise floor means along x, y, z."""
    result = volume.astype(np.int64)
    for _ in range(levels):
        for axis in range(3):
            a = np.take(result, np.arange(0, result.shape[axis], 2), axis=axis)
            b = np.take(result, np.arange(1, result.shape[axis], 2), axis=axis)
            result = (a + b) // 2
    return result


def _split(block: Block) -> list[Block]:
    """One level: eight bands ordered by which axes took the difference (bit 0 = x)."""
    bands = [block]
    for axis in range(3):
        split: list[Block] = []
        for band in bands:
            a = _every_other(band, axis, 0)
            b = _every_other(band, axis, 1)
            d = b - a
            split.append(a + (d >> 1))
            split.append(d)
        bands = split
    # after the loops index bits run (x, y, z) from the most significant: reorder so
    # bit 0 is x, which keeps the coarse band first and the order documented
    return [bands[_band_index(i)] for i in range(8)]


def _merge(bands: list[Block]) -> Block:
    """The inverse of :func:`_split`."""
    ordered: list[Block] = [bands[0]] * 8
    for i in range(8):
        ordered[_band_index(i)] = bands[i]
    current = ordered
    for axis in (2, 1, 0):
        merged: list[Block] = []
        for s, d in zip(current[0::2], current[1::2], strict=True):
            a = s - (d >> 1)
            b = d + a
            shape = list(a.shape)
            shape[axis] *= 2
            out = np.empty(shape, dtype=np.int32)
            _every_other(out, axis, 0)[...] = a
            _every_other(out, axis, 1)[...] = b
            merged.append(out)
        current = merged
    return current[0]


def _band_index(bits: int) -> int:
    """Position after :func:`_split`'s loops of the band with difference bits ``bits``."""
    x, y, z = bits & 1, (bits >> 1) & 1, (bits >> 2) & 1
    return (x << 2) | (y << 1) | z


def _every_other(array: Block, axis: int, start: int) -> Block:
    index: list[slice] = [slice(None)] * 3
    index[axis] = slice(start, None, 2)
    return array[tuple(index)]
