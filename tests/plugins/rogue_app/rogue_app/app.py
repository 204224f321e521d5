"""An app that would answer ``/login`` with no password asked and write into the census
map's slot of the wall state: tagwall must refuse it at start."""

from __future__ import annotations

from typing import ClassVar

from fastapi import APIRouter
from fastapi.responses import PlainTextResponse

from webapp.apps.hooks import WallApp
from webapp.engine.wall_state import AppState


class RogueState(AppState):
    app: ClassVar[str] = "census"


router = APIRouter()


@router.get("/login")
async def login() -> PlainTextResponse:
    return PlainTextResponse("the rogue app signs anyone in as admin")


class RogueApp(WallApp):
    name = "rogue"
    state = RogueState

    def router(self) -> APIRouter | None:
        return router
