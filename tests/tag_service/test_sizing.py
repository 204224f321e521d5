"""Code size follows from the scanning distance and each display's pixel pitch."""

import math

import pytest

from tag_service.sizing import (
    MIN_PX_PER_MODULE,
    Camera,
    code_size,
    min_module_mm,
    symbol_modules,
)
from wall_client.config import load_wall
from webapp.core.settings import CONTENT_DIR


def test_module_size_is_about_distance_over_305() -> None:
    """4.5 camera pixels per module: zbar's need in full phone frames (docs/codes.md)."""
    assert min_module_mm(1.0) == pytest.approx(1000 * 2 * math.tan(math.radians(35)) * 4.5 / 1920)
    assert min_module_mm(1.0) == pytest.approx(1000 / 305, rel=0.01)
    assert min_module_mm(3.0) == pytest.approx(3 * min_module_mm(1.0))


def test_a_narrower_camera_allows_smaller_modules() -> None:
    assert min_module_mm(2.0, Camera(field_of_view_deg=50)) < min_module_mm(2.0)


@pytest.mark.parametrize("distance", [0.0, -1.0])
def test_distance_must_be_positive(distance: float) -> None:
    with pytest.raises(ValueError, match="positive"):
        min_module_mm(distance)


def test_quiet_zone_is_four_modules_a_side() -> None:
    assert symbol_modules(25) == 33


def test_whole_pixels_per_module_covering_the_minimum() -> None:
    demo = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    display = demo.displays[0]  # 55", 0.63 mm pixels
    size = code_size(display, 33, min_module_mm(2.0))
    assert size.px_per_module == math.ceil(min_module_mm(2.0) / display.mm_per_px)
    assert size.module_mm >= min_module_mm(2.0)
    assert size.side_px == 33 * size.px_per_module
    assert size.side_mm == pytest.approx(size.side_px * display.mm_per_px)


def test_never_fewer_than_three_pixels_per_module() -> None:
    demo = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    assert code_size(demo.displays[0], 33, 0.01).px_per_module == MIN_PX_PER_MODULE


def test_a_larger_preferred_size_is_honoured_in_whole_pixels() -> None:
    demo = load_wall(CONTENT_DIR / "walls" / "demo.toml")
    display = demo.displays[0]
    size = code_size(display, 33, min_module_mm(1.0), preferred_mm=400)
    assert size.side_mm <= 400 < size.side_mm + 33 * display.mm_per_px
    smaller = code_size(display, 33, min_module_mm(2.0), preferred_mm=10)
    assert smaller == code_size(display, 33, min_module_mm(2.0))
