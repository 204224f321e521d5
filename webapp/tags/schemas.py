"""Codes as they stand on the wall, as the API, tiles, apps and ``tagwall check`` read
them; what an operator may change on a tag."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field


class PlacedCode(BaseModel):
    """A code as it stands on the wall: what tiles draw and ``tagwall check`` verifies."""

    code: str
    label: str
    kind: str
    payload: str  # what the symbol encodes (``tagwall check`` compares decodes with it)
    display: str
    rect: tuple[float, float, float, float]  # scene mm, on the display's pixel grid
    pixels: tuple[int, int, int]  # x, y, side in the display's pixels (as mounted)
    px_per_module: int
    modules: int  # across, quiet zone included
    error: str
    version: int
    matrix: list[str]  # rows of modules, "1" dark, quiet zone excluded
    anchor: tuple[float, float]
    leader: tuple[tuple[float, float], tuple[float, float]] | None
    caption: tuple[float, float, float, float] | None = None  # scene mm: where its label stands
    purpose: Literal["walk-up", "seat"] = "walk-up"  # which design distance sized it

    @property
    def footprint(self) -> tuple[float, float, float, float]:
        """The code with its caption (scene mm): what balloons and labels keep clear of."""
        x, y, w, _ = self.rect
        if self.caption is None:
            return self.rect
        cx, cy, cw, ch = self.caption
        left, right = min(x, cx), max(x + w, cx + cw)
        return (left, y, right - left, cy + ch - y)


class UnplacedCode(BaseModel):
    code: str
    label: str
    reason: str


class LayoutInfo(BaseModel):
    """One placement of a wall's tag set (immutable: cached by id)."""

    id: int
    wall: str
    tag_set: str | None
    placed: list[PlacedCode]
    unplaced: list[UnplacedCode]


class TagUpdate(BaseModel):
    """What an operator may change on a tag; its code and purpose stay."""

    model_config = ConfigDict(extra="forbid")

    label: str | None = Field(default=None, max_length=200)
    active: bool | None = None
    expires_at: datetime | None = None
