"""The lossless integer Haar lifting: exact round trips, coarse-first prefixes."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from webapp.volume.wavelet import downsample, forward, inverse, prefix_length

SIZES = (2, 4, 8, 16, 32)
DTYPES: list[type[np.integer[Any]]] = [np.uint8, np.int16]


def random_block(size: int, dtype: type[np.integer[Any]], seed: int) -> npt.NDArray[Any]:
    """A cube of random values over the whole range of ``dtype`` (negatives included)."""
    info = np.iinfo(dtype)
    rng = np.random.default_rng(seed)
    return rng.integers(info.min, int(info.max) + 1, size=(size,) * 3).astype(dtype)


@st.composite
def blocks(draw: st.DrawFn) -> tuple[npt.NDArray[Any], int]:
    """A random uint8 or int16 cube of side 2..32 and a level count that divides it."""
    size = draw(st.sampled_from(SIZES))
    levels = draw(st.integers(0, size.bit_length() - 1))
    dtype = draw(st.sampled_from(DTYPES))
    seed = draw(st.integers(0, 2**32 - 1))
    return random_block(size, dtype, seed), levels


def floor_means(volume: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """One halving written out element by element: pairwise floor means along x, then
    y, then z (the documented order)."""
    nx, ny, nz = volume.shape
    along_x = [
        [
            [(int(volume[2 * x, y, z]) + int(volume[2 * x + 1, y, z])) // 2 for z in range(nz)]
            for y in range(ny)
        ]
        for x in range(nx // 2)
    ]
    along_y = [
        [
            [(along_x[x][2 * y][z] + along_x[x][2 * y + 1][z]) // 2 for z in range(nz)]
            for y in range(ny // 2)
        ]
        for x in range(nx // 2)
    ]
    along_z = [
        [
            [(along_y[x][y][2 * z] + along_y[x][y][2 * z + 1]) // 2 for z in range(nz // 2)]
            for y in range(ny // 2)
        ]
        for x in range(nx // 2)
    ]
    return np.array(along_z, dtype=np.int64)


@settings(max_examples=50, deadline=None)
@given(blocks())
def test_round_trip_is_exact(case: tuple[npt.NDArray[Any], int]) -> None:
    block, levels = case
    stream = forward(block, levels)
    assert stream.ndim == 1 and stream.size == block.size
    np.testing.assert_array_equal(inverse(stream, block.shape[0], levels), block)


@pytest.mark.parametrize("dtype", [np.uint8, np.int16])
@pytest.mark.parametrize("levels", [0, 1, 2, 3, 4])
def test_round_trip_is_exact_for_every_level_count(
    dtype: type[np.integer[Any]], levels: int
) -> None:
    block = random_block(16, dtype, seed=levels)
    if dtype is np.int16:
        assert block.min() < 0  # the negative range is exercised
    np.testing.assert_array_equal(inverse(forward(block, levels), 16, levels), block)


@settings(max_examples=50, deadline=None)
@given(blocks())
def test_every_prefix_rebuilds_the_downsampled_block(
    case: tuple[npt.NDArray[Any], int],
) -> None:
    block, levels = case
    size = block.shape[0]
    stream = forward(block, levels)
    for level in range(levels + 1):
        prefix = stream[: prefix_length(size, level)]
        rebuilt = inverse(prefix, size, levels, level)
        assert rebuilt.shape == (size >> level,) * 3
        np.testing.assert_array_equal(rebuilt, downsample(block, level))


def test_prefix_length_counts_the_voxels_of_the_level() -> None:
    assert [prefix_length(32, level) for level in range(6)] == [32768, 4096, 512, 64, 8, 1]


def test_downsample_of_a_2x2x2_block_matches_the_hand_computed_floor_means() -> None:
    # block[x, y, z]:
    #   x=0: [[ 3, -2], [ 7, 0]]     x=1: [[ 4, -5], [ 1, 9]]
    block = np.array([[[3, -2], [7, 0]], [[4, -5], [1, 9]]])
    # along x: (3+4)//2=3, (-2-5)//2=-4, (7+1)//2=4, (0+9)//2=4  -> [[3, -4], [4, 4]]
    # along y: (3+4)//2=3, (-4+4)//2=0                           -> [3, 0]
    # along z: (3+0)//2=1
    np.testing.assert_array_equal(downsample(block, 1), [[[1]]])
    # level 0 is the block itself
    np.testing.assert_array_equal(downsample(block, 0), block)


def test_downsample_floors_negative_means_downwards() -> None:
    # along x: (-1+0)//2 = -1 (floor, not truncation towards zero), likewise every pair
    block = np.array([[[-1, -1], [-1, -1]], [[0, 0], [0, 0]]])
    np.testing.assert_array_equal(downsample(block, 1), [[[-1]]])


def test_downsample_of_a_4x4x4_block_matches_the_explicit_floor_means() -> None:
    block = random_block(4, np.int16, seed=11).astype(np.int64) // 100  # small, signed
    once = floor_means(block)
    twice = floor_means(once)
    np.testing.assert_array_equal(downsample(block, 1), once)
    np.testing.assert_array_equal(downsample(block, 2), twice)


def test_downsample_of_a_structured_4x4x4_block_is_the_hand_computed_one() -> None:
    # block[x, y, z] = 16x + 4y + z; a pair along x averages 16x to 16*(2X)+8, along y
    # 4y to 4*(2Y)+2, along z z to 2Z + 0 (floor of .5): the level-1 voxel is
    # 32X + 8 + 8Y + 2 + 2Z
    block = np.arange(64).reshape(4, 4, 4)
    expected = np.array(
        [[[32 * x + 8 * y + 2 * z + 10 for z in range(2)] for y in range(2)] for x in range(2)]
    )
    np.testing.assert_array_equal(downsample(block, 1), expected)
    # level 2 averages those: x: 32*0 + 16 = 16, y: 8*0 + 4 = 4, z: floor(2*0.5) = 1
    np.testing.assert_array_equal(downsample(block, 2), [[[10 + 16 + 4 + 1]]])


@pytest.mark.parametrize("shape", [(4, 4, 2), (4, 2, 4), (2, 4, 4), (4, 4), (4, 4, 4, 4)])
def test_forward_refuses_a_block_that_is_not_a_cube(shape: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match="cube"):
        forward(np.zeros(shape, dtype=np.int32), 1)


@pytest.mark.parametrize(("size", "levels"), [(6, 2), (3, 1), (12, 3), (8, 4)])
def test_forward_refuses_a_side_not_divisible_by_two_to_the_levels(size: int, levels: int) -> None:
    with pytest.raises(ValueError, match=rf"2\*\*{levels}"):
        forward(np.zeros((size,) * 3, dtype=np.int32), levels)


@pytest.mark.parametrize("level", [-1, 3, 10])
def test_inverse_refuses_a_level_outside_the_stored_levels(level: int) -> None:
    stream = forward(random_block(8, np.uint8, seed=1), 2)
    with pytest.raises(ValueError, match="between 0 and 2"):
        inverse(stream, 8, 2, level)


def checkerboard(size: int) -> npt.NDArray[Any]:
    """0 and 255 alternating along every axis: the largest differences uint8 allows."""
    x, y, z = np.indices((size,) * 3)
    board: npt.NDArray[Any] = (255 * ((x + y + z) % 2)).astype(np.uint8)
    return board


@pytest.mark.parametrize(
    "block",
    [
        checkerboard(16),
        255 - checkerboard(16),
        random_block(16, np.uint8, seed=5),
        np.full((16,) * 3, 255, dtype=np.uint8),
    ],
    ids=["checkerboard", "inverted-checkerboard", "random", "full"],
)
def test_uint8_coefficients_fit_in_int16(block: npt.NDArray[Any]) -> None:
    wide = forward(block, 4)
    info = np.iinfo(np.int16)
    assert info.min <= int(wide.min()) and int(wide.max()) <= info.max
    narrow = forward(block, 4, np.int16)
    assert narrow.dtype == np.int16
    np.testing.assert_array_equal(narrow, wide)  # nothing wrapped around
    np.testing.assert_array_equal(inverse(narrow, 16, 4), block)


@settings(max_examples=30, deadline=None)
@given(st.sampled_from(SIZES), st.integers(0, 2**32 - 1), st.data())
def test_uint8_coefficients_fit_in_int16_for_random_blocks(
    size: int, seed: int, data: st.DataObject
) -> None:
    levels = data.draw(st.integers(0, size.bit_length() - 1))
    stream = forward(random_block(size, np.uint8, seed), levels)
    assert np.abs(stream).max() <= np.iinfo(np.int16).max
