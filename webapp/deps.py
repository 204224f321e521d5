"""FastAPI dependencies: every lookup and privilege check of a request lives here.

They are ``async`` although none awaits: FastAPI runs plain ``def`` dependencies in
the thread pool, a hop that cost more than the work itself on every request.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Query, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from wall_client.layout import Display, Wall
from webapp.security import token_matches
from webapp.services import Services


async def get_services(request: Request) -> Services:
    services: Services = request.app.state.services
    return services


ServicesDep = Annotated[Services, Depends(get_services)]


async def get_wall(wall_id: str, services: ServicesDep) -> Wall:
    wall = services.walls.get(wall_id)
    if wall is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no wall called {wall_id!r}.")
    return wall


WallDep = Annotated[Wall, Depends(get_wall)]


async def get_tile(tile_id: str, wall: WallDep) -> Display:
    for display in wall.displays:
        if display.id == tile_id:
            return display
    raise HTTPException(
        status.HTTP_404_NOT_FOUND, f"Wall {wall.id!r} has no tile called {tile_id!r}."
    )


TileDep = Annotated[Display, Depends(get_tile)]


async def require_tile_token(
    wall: WallDep, services: ServicesDep, token: Annotated[str | None, Query()] = None
) -> None:
    """Tile pages need the wall's tile token (printed by ``tagwall tiles``)."""
    if not token_matches(services.tile_token(wall.id), token):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "This tile URL has a missing or wrong token; use the URL from `tagwall tiles`.",
        )


TileTokenDep = Depends(require_tile_token)

_bearer = HTTPBearer(auto_error=False)


async def require_operator(
    services: ServicesDep,
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
) -> None:
    """State-changing API calls need the operator token as a bearer token."""
    given = credentials.credentials if credentials else None
    if not token_matches(services.operator_token, given):
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            "This needs the operator token (Authorization: Bearer ...).",
            headers={"WWW-Authenticate": "Bearer"},
        )


OperatorDep = Depends(require_operator)


async def require_operator_page(
    services: ServicesDep, token: Annotated[str | None, Query()] = None
) -> str:
    """The dashboard page carries the operator token in its URL, like tile URLs."""
    if not token_matches(services.operator_token, token):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "The dashboard URL needs the operator token; `tagwall urls` prints it.",
        )
    return services.operator_token


OperatorPageDep = Annotated[str, Depends(require_operator_page)]
