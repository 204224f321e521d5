"""How big a code must be on a display so a phone reads it from the design distance.

A phone camera decodes a QR symbol reliably when each module covers about four and a
half camera pixels (measured with ``tag_service.verify.phone_frame``, docs/codes.md).
A camera with a horizontal field of view ``fov`` that delivers frames ``frame_px``
wide sees, at distance ``d``, a strip ``2 d tan(fov / 2)`` wide, so one camera pixel
spans ``2 d tan(fov / 2) / frame_px`` and a module must span at least
``camera_px_per_module`` of those::

    module_mm >= d * 2 tan(fov / 2) * camera_px_per_module / frame_px

With the defaults (70 degrees, 1920 px, 4.5 px per module) that is about d / 305:
2.6 mm at 0.8 m, 6.6 mm at 2 m. Each wall says its design distances per purpose:
walk-up codes marking the scene, seat codes serving the room
(``Wall.design_distance_m``). On a display a module is an integer number of
pixels (never fewer than three, so one lost pixel row cannot break a module),
and every symbol keeps a quiet zone of four modules on each side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from wall_client.layout import Display

FIELD_OF_VIEW_DEG = 70.0
CAMERA_FRAME_PX = 1920
CAMERA_PX_PER_MODULE = 4.5  # zbar reads 3 in 4 frames at 4.0, 99 in 100 at 4.5
MIN_PX_PER_MODULE = 3
QUIET_ZONE_MODULES = 4
_ROUNDING_SLACK = 1e-9


@dataclass(frozen=True)
class Camera:
    """The phone camera a wall is designed for."""

    field_of_view_deg: float = FIELD_OF_VIEW_DEG
    frame_px: int = CAMERA_FRAME_PX
    px_per_module: float = CAMERA_PX_PER_MODULE

    def mm_per_camera_px(self, distance_m: float) -> float:
        """The width of wall one camera pixel sees at ``distance_m``."""
        half_angle = math.radians(self.field_of_view_deg) / 2
        return distance_m * 1000 * 2 * math.tan(half_angle) / self.frame_px


def min_module_mm(distance_m: float, camera: Camera = Camera()) -> float:
    """The smallest module (mm) a phone at ``distance_m`` decodes reliably."""
    if distance_m <= 0:
        raise ValueError(f"scanning distance must be positive, not {distance_m}")
    return camera.mm_per_camera_px(distance_m) * camera.px_per_module


def symbol_modules(version_width: int) -> int:
    """Modules across a symbol of ``version_width`` modules, quiet zone included."""
    return version_width + 2 * QUIET_ZONE_MODULES


@dataclass(frozen=True)
class CodeSize:
    """A code as drawn on one display."""

    display_id: str
    px_per_module: int
    modules: int  # across, quiet zone included
    mm_per_px: float  # the display's physical pixel pitch

    @property
    def side_px(self) -> int:
        return self.px_per_module * self.modules

    @property
    def module_mm(self) -> float:
        return self.px_per_module * self.mm_per_px

    @property
    def side_mm(self) -> float:
        return self.side_px * self.mm_per_px


def code_size(
    display: Display, modules: int, module_mm: float, preferred_mm: float | None = None
) -> CodeSize:
    """The code of ``modules`` across on ``display``: modules of at least ``module_mm``.

    Pixels per module are rounded up to a whole number (never below three); a larger
    ``preferred_mm`` side is honoured, rounded down to whole pixels per module.
    """
    pitch = display.mm_per_px
    ppm = max(MIN_PX_PER_MODULE, math.ceil(module_mm / pitch - _ROUNDING_SLACK))
    if preferred_mm is not None:
        ppm = max(ppm, math.floor(preferred_mm / (modules * pitch) + _ROUNDING_SLACK))
    return CodeSize(display.id, ppm, modules, pitch)
