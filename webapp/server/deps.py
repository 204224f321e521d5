"""Dependencies of the core's own routes: the whole of what the server holds.

Apps get the narrower ``ContextDep`` of :mod:`webapp.web.deps`.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Request, WebSocket, status

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp
from webapp.apps.installed import modes_of
from webapp.engine.protocol import CLOSE_UNKNOWN
from webapp.server.services import Services


async def get_services(request: Request) -> Services:
    services: Services = request.app.state.services
    return services


ServicesDep = Annotated[Services, Depends(get_services)]


async def open_wall_socket(
    websocket: WebSocket, wall_id: str, tile_id: str | None = None
) -> tuple[Services, Wall] | None:
    """Accept a websocket of one wall (and tile): the services and the wall, or None
    when the socket was closed because there is no such wall or tile. Sockets close
    with a code of their own rather than an HTTP status, so this is not a dependency."""
    services: Services = websocket.app.state.services
    await websocket.accept()
    wall = services.walls.get(wall_id)
    if wall is None or (tile_id is not None and tile_id not in {d.id for d in wall.displays}):
        await websocket.close(CLOSE_UNKNOWN, "unknown wall or tile" if tile_id else "unknown wall")
        return None
    return services, wall


def showable_app(services: Services, name: str, mode: str | None = None) -> WallApp:
    """The app ``name`` a wall can show, in ``mode`` when one is named (one of its
    modes; ``default`` for an app without modes): a 422 naming what there is else."""
    app = services.wall_apps.get(name)
    if app is None:
        known = ", ".join(sorted(services.wall_apps))
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"There is no app {name!r} (installed: {known})."
        )
    if mode is not None and mode not in modes_of(app):
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT,
            f"The {name} app has no mode {mode!r} (its modes: {', '.join(modes_of(app))}).",
        )
    return app
