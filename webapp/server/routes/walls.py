"""The walls API: layouts for everyone, status and state changes for the operator."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status

from wall_client.layout import Wall
from webapp.core.threads import run_blocking
from webapp.engine.hub import TileStatus
from webapp.engine.wall_state import StatePatch, read_state
from webapp.server.deps import ServicesDep
from webapp.server.schemas import ChangeResult, TileStatusInfo, WallInfo, WallStatus
from webapp.server.services import Services
from webapp.web.deps import StaffOnly, WallDep

router = APIRouter(prefix="/api/walls", tags=["walls"])


@router.get("")
def list_walls(services: ServicesDep) -> list[WallInfo]:
    return [WallInfo.of(wall) for wall in services.walls.values()]


@router.get("/{wall_id}")
def get_wall(wall: WallDep) -> WallInfo:
    return WallInfo.of(wall)


@router.get("/{wall_id}/status", dependencies=[StaffOnly])
async def wall_status(wall: WallDep, services: ServicesDep) -> WallStatus:
    return await status_of(services, wall)


async def status_of(services: Services, wall: Wall) -> WallStatus:
    """The wall's version and state, and what each tile last reported."""
    version, state = await run_blocking(read_state, services.db, wall.id)
    statuses = services.hub.tile_statuses(wall.id)
    tiles = [
        TileStatusInfo.of(statuses.get(d.id) or TileStatus(tile_id=d.id)) for d in wall.displays
    ]
    return WallStatus(
        wall=wall.id, version=version, state=state.model_dump(mode="json"), tiles=tiles
    )


@router.post("/{wall_id}/state", dependencies=[StaffOnly])
async def change_wall_state(
    wall: WallDep, patch: StatePatch, services: ServicesDep
) -> ChangeResult:
    if patch.app is not None and patch.app not in services.wall_apps:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"There is no app called {patch.app!r}; apps: {', '.join(sorted(services.wall_apps))}.",
        )
    if patch.volume is not None and patch.volume.volume not in services.volumes:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"There is no volume called {patch.volume.volume!r}; "
            "build one with `tagwall volume build`.",
        )
    change = await services.change_wall(wall, patch.apply_to)
    if change is None:
        version, _ = await run_blocking(read_state, services.db, wall.id)
        return ChangeResult(wall=wall.id, version=version, changed=[])
    return ChangeResult(wall=wall.id, version=change.version, changed=sorted(change.changes))
