"""HTTP API models (websocket messages are in ``protocol``)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from wall_client.layout import Wall
from webapp.hub import TileStatus


class DisplayInfo(BaseModel):
    id: str
    rect: tuple[float, float, float, float]
    resolution: tuple[int, int]
    rotation: int
    node: str
    index: int
    roles: list[str]
    scene_rect: tuple[float, float, float, float]
    to_wall: tuple[float, float, float, float, float, float]


class WallInfo(BaseModel):
    """A wall's layout as the overview and the dashboard draw it."""

    id: str
    name: str
    width: float
    height: float
    bezel_mode: str
    displays: list[DisplayInfo]

    @classmethod
    def of(cls, wall: Wall) -> WallInfo:
        roles = {
            display_id: [role for role, ids in wall.screens.items() if display_id in ids]
            for display_id in (d.id for d in wall.displays)
        }
        displays = []
        for display in wall.displays:
            viewport = wall.viewport(display.id)
            displays.append(
                DisplayInfo(
                    id=display.id,
                    rect=display.rect.xywh,
                    resolution=display.resolution,
                    rotation=display.rotation,
                    node=display.node,
                    index=display.index,
                    roles=roles[display.id],
                    scene_rect=viewport.scene_rect.xywh,
                    to_wall=viewport.to_wall,
                )
            )
        return cls(
            id=wall.id,
            name=wall.name,
            width=wall.width,
            height=wall.height,
            bezel_mode=wall.bezel_mode,
            displays=displays,
        )


class TileStatusInfo(BaseModel):
    tile_id: str
    connected: bool
    connections: int
    connected_since: int | None
    last_seen: int | None
    version: int | None
    applied_at: float | None
    address: str | None

    @classmethod
    def of(cls, status: TileStatus) -> TileStatusInfo:
        return cls(connected=status.connections > 0, **vars(status))


class WallStatus(BaseModel):
    wall: str
    version: int
    state: dict[str, Any]
    tiles: list[TileStatusInfo]


class ChangeResult(BaseModel):
    wall: str
    version: int
    changed: list[str]
