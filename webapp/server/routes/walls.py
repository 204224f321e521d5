"""The walls API: layouts for everyone, status and state changes for the operator."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status

from wall_client.layout import Wall
from webapp.core.threads import run_blocking
from webapp.engine.hub import TileStatus
from webapp.engine.wall_state import StatePatch, WallState, read_state
from webapp.quiz.engine import QuizError
from webapp.server.deps import ServicesDep, showable_app
from webapp.server.schemas import ChangeResult, TileStatusInfo, WallInfo, WallStatus
from webapp.server.services import Services
from webapp.web.context import Update
from webapp.web.deps import StaffOnly, WallDep
from webapp.web.problems import errors

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


@router.post("/{wall_id}/state", dependencies=[StaffOnly], responses=errors(409))
async def change_wall_state(
    wall: WallDep, patch: StatePatch, services: ServicesDep
) -> ChangeResult:
    """Change the core's fields of the wall state. A mode is the app's: a change of mode
    goes through the app's ``switch_mode`` (the brain opens or closes its round)."""
    if patch.app is not None:
        showable_app(services, patch.app)
    if patch.volume is not None and patch.volume.volume not in services.volumes:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"There is no volume called {patch.volume.volume!r}; "
            "build one with `tagwall volume build`.",
        )
    fields = patch.model_dump(exclude_unset=True, exclude={"mode"})
    without_mode = StatePatch.model_validate(fields)

    async def plan(current: WallState) -> Update:
        patched = without_mode.apply_to(current)
        if patch.mode is None:
            return lambda _held: patched
        app = showable_app(services, patched.app, patch.mode)
        if patch.mode != current.mode:
            try:
                patched = await run_blocking(app.switch_mode, services, wall, patched, patch.mode)
            except QuizError as error:
                raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from error
        return lambda _held: patched

    change = await services.plan_change(wall, plan)
    if change is None:
        version, _ = await run_blocking(read_state, services.db, wall.id)
        return ChangeResult(wall=wall.id, version=version, changed=[])
    return ChangeResult(wall=wall.id, version=change.version, changed=sorted(change.changes))
