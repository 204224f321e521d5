"""The colours of a volume: each transfer preset a volume layer names
(:class:`~webapp.engine.wall_state.VolumeLayer`), as control points and as a table."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from webapp.engine.wall_state import TransferName

# Control points: value (fraction of the volume's range), colour, opacity per mm.
ControlPoint = tuple[float, str, float]
TRANSFER_PRESETS: dict[TransferName, tuple[ControlPoint, ...]] = {
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


def lookup_table(name: TransferName, entries: int = 256) -> npt.NDArray[Any]:
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
