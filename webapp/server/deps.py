"""Dependencies of the core's own routes: the whole of what the server holds.

Apps get the narrower ``ContextDep`` of :mod:`webapp.web.deps`.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request, WebSocket

from wall_client.layout import Wall
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
