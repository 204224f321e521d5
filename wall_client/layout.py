"""Wall geometry: a wall config becomes displays, and each display a viewport.

This module is the only home of wall geometry. The server computes every tile's
viewport here and sends it; tile JavaScript applies the matrices it is given and
never re-derives geometry.

Coordinates are physical millimetres on the wall, origin at the top-left corner,
x to the right, y downwards. The *scene* is authored in the same coordinates over
the wall's full extent. In bezel mode ``overlay`` a display shows exactly the scene
under its active area (what lies behind a bezel is hidden, lines stay straight).
In mode ``offset`` the uncovered bands (bezels, gaps) are squeezed out along each
axis and the remaining coverage is stretched back to the wall's extent, so the
pixels of neighbouring displays are concatenated.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

BezelMode = Literal["overlay", "offset"]
Rotation = Literal[0, 90, 180, 270]
ROLES: tuple[str, ...] = ("public", "menu", "registration")

# An affine map (a, b, c, d, e, f) as in CSS/canvas ``setTransform``:
# x' = a*x + c*y + e ; y' = b*x + d*y + f
Affine = tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in wall millimetres."""

    x: float
    y: float
    width: float
    height: float


@dataclass(frozen=True)
class Display:
    """One monitor: its active area on the wall and how it is driven."""

    id: str
    rect: Rect  # active area as mounted, wall mm
    resolution: tuple[int, int]  # native framebuffer pixels (unrotated), as the OS drives it
    rotation: Rotation  # clockwise rotation of the panel as mounted
    node: str  # render node (host) that drives it, for the kiosk launcher
    index: int  # display index on that node (0 = primary)
    desktop_origin: tuple[int, int]  # top-left of this display in the node's desktop, px


@dataclass(frozen=True)
class Viewport:
    """What one tile shows: a scene rectangle and the maps that draw it."""

    display_id: str
    scene_rect: Rect  # part of the scene this display shows (scene mm)
    pixels: tuple[int, int]  # window size in px (the native resolution)
    to_pixels: Affine  # scene mm -> window px (rotation included)
    to_wall: Affine  # scene mm -> physical wall mm (identity in overlay mode)


@dataclass(frozen=True)
class Wall:
    """A validated wall: displays, designated screens, bezel mode."""

    id: str
    name: str
    width: float  # wall extent, mm
    height: float
    displays: tuple[Display, ...]
    bezel_mode: BezelMode
    screens: dict[str, tuple[str, ...]]  # role -> display ids
    scan_distance_m: float  # design scanning distance (tag sizing uses it)
    source: Path | None = None
