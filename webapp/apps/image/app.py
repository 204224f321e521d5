"""The image app as a wall app: an instructor's image filling the wall's stage, panned
and zoomed with the core's view; no codes of its own yet (hotspots come next)."""

from __future__ import annotations

from pathlib import Path

import click
from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps.contract import Export, Scan, static_url
from webapp.apps.image import commands, routes
from webapp.apps.image.library import ImageLibrary
from webapp.apps.image.state import APP, ImageState
from webapp.classes.roll import ClassSession
from webapp.engine.wall_state import AppState, WallState
from webapp.publishing.publication import Publication
from webapp.tags.registry import TagSpec
from webapp.web.context import AppContext

FOLDER = Path(__file__).parent


class ImageApp(ImageLibrary):
    """The image app's :class:`~webapp.apps.contract.WallApp`: its store with what the
    core calls."""

    name: str = APP
    state: type[AppState] | None = ImageState
    default_tag_set: str | None = None
    layers: tuple[str, ...] = (f"{static_url(APP)}/image.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"
    class_modes: tuple[str, ...] = ()

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """Coming on a wall that never chose an image, it shows the newest one (the
        one just added, as a rule)."""
        if ImageState.of(state).image is not None:
            return state
        newest = self.store(context.settings).images()
        return ImageState(image=newest[0].id).put(state) if newest else state

    def leave(self, state: WallState) -> WallState:
        return state  # its slot stays for its return

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        return []

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        return []

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        return state

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        return state

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        return []

    async def on_scan(self, scan: Scan) -> Response:
        return Response(status_code=404)  # it declares no codes: never called

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        return None

    async def publication(self, scan: Scan) -> Publication | None:
        return None

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "image/panel.html"

    def router(self) -> APIRouter | None:
        return routes.router

    def commands(self) -> list[click.Command]:
        return [commands.image]
