"""What the wall shows of a volume: which one, how (mode, colours) and which part.

The orientation, centre and zoom are the wall's ``view`` (shared by every layer);
this layer adds what only volumes have. It is part of the wall state, so changing
it is a heavy change: tiles fetch their new images before the swap.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field, model_validator

Mode = Literal["composite", "mip", "slice"]
Interval = tuple[float, float]

# Control points: value (fraction of the volume's range), colour, opacity per mm.
ControlPoint = tuple[float, str, float]
TRANSFER_PRESETS: dict[str, tuple[ControlPoint, ...]] = {
    "grey": (
        (0.0, "#000000", 0.0),
        (0.12, "#1a1a1a", 0.0),
        (0.35, "#8a8a8a", 0.02),
        (0.7, "#e6e6e6", 0.12),
        (1.0, "#ffffff", 0.5),
    ),
    "tissue": (
        (0.0, "#000000", 0.0),
        (0.15, "#3a1810", 0.0),
        (0.4, "#b5523b", 0.03),
        (0.7, "#f2c6a0", 0.15),
        (1.0, "#fff6ea", 0.6),
    ),
    "hot": (
        (0.0, "#000000", 0.0),
        (0.2, "#300000", 0.0),
        (0.5, "#d02000", 0.04),
        (0.8, "#ffc000", 0.2),
        (1.0, "#ffffff", 0.6),
    ),
}
TRANSFER_NAMES = tuple(TRANSFER_PRESETS)


class VolumeLayer(BaseModel):
    """A volume on the wall: its store name, render mode, colours and clipping."""

    model_config = ConfigDict(extra="forbid")

    volume: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    mode: Mode = "composite"
    transfer: Literal["grey", "tissue", "hot"] = "grey"
    # the part of the volume kept, as fractions of its extent along x, y and z
    clip: tuple[Interval, Interval, Interval] = ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))
    # slice mode: the plane's distance from the centre along the view direction, as a
    # fraction of half the volume's diagonal (0 = through the centre)
    slice: float = Field(default=0.0, ge=-1.0, le=1.0)

    @model_validator(mode="after")
    def _clip_intervals(self) -> VolumeLayer:
        for axis, (low, high) in zip("xyz", self.clip, strict=True):
            if not 0.0 <= low < high <= 1.0:
                raise ValueError(f"clip along {axis} must satisfy 0 <= low < high <= 1")
        return self


def lookup_table(name: str, entries: int = 256) -> npt.NDArray[Any]:
    """The preset as ``entries`` rows of (red, green, blue, opacity per mm), 0..1."""
    points = TRANSFER_PRESETS[name]
    at = np.array([p[0] for p in points])
    colours = np.array([[int(p[1][i : i + 2], 16) / 255 for i in (1, 3, 5)] for p in points])
    opacity = np.array([p[2] for p in points])
    x = np.linspace(0.0, 1.0, entries)
    table = np.empty((entries, 4), dtype=np.float32)
    for channel in range(3):
        table[:, channel] = np.interp(x, at, colours[:, channel])
    table[:, 3] = np.interp(x, at, opacity)
    return table
