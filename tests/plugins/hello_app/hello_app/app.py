"""The hello app: what any department's own app looks like, written on the contract alone.

It keeps a greeting in its slot of the wall state, draws it across every tile (its
layer), stands one code in the middle of the wall, answers its scan with a phone page,
takes a new greeting from instructors (its API) and adds a ``tagwall hello`` command.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, ClassVar

import click
from fastapi import APIRouter, Body, Response

from wall_client.layout import Wall
from webapp.apps.hooks import Scan, WallApp, static_url
from webapp.engine.wall_state import AppState, WallState
from webapp.publishing.publication import Block, Publication
from webapp.tags.registry import TagSpec
from webapp.web.context import AppContext
from webapp.web.deps import ContextDep, StaffOnly, WallDep
from webapp.web.templating import render

APP = "hello"
FOLDER = Path(__file__).parent


class HelloState(AppState):
    app: ClassVar[str] = APP
    heavy: ClassVar[frozenset[str]] = frozenset({"greeting"})

    greeting: str = "Hello, wall"


router = APIRouter()


@router.post("/api/apps/hello/walls/{wall_id}/greeting", dependencies=[StaffOnly])
async def set_greeting(
    wall: WallDep, context: ContextDep, greeting: Annotated[str, Body(embed=True, max_length=80)]
) -> dict[str, str]:
    await context.change_wall(wall, HelloState(greeting=greeting).put)
    return {"greeting": greeting}


@click.command("hello")
def hello() -> None:
    """Say hello (an app's own command)."""
    click.echo("hello from an installed app")


class HelloApp(WallApp):
    name: str = APP
    state: type[AppState] | None = HelloState
    layers: tuple[str, ...] = (f"{static_url(APP)}/hello.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        if state.app != APP:
            return []
        stage = wall.stage
        middle = (stage.x + stage.width / 2, stage.y + stage.height / 2)
        return [TagSpec(name="hello:wave", label="Wave", app=APP, action="wave", anchor=middle)]

    async def on_scan(self, scan: Scan) -> Response:
        state = await scan.context.state(scan.wall)
        greeting = HelloState.of(state).greeting
        return render(scan.request, "hello/page.html", wall=scan.wall, greeting=greeting)

    async def publication(self, scan: Scan) -> Publication | None:
        state = await scan.context.state(scan.wall)
        text = HelloState.of(state).greeting
        return Publication(title="Hello", blocks=[Block(kind="text", text=text)])

    def router(self) -> APIRouter | None:
        return router

    def commands(self) -> list[click.Command]:
        return [hello]
