"""A sun drawn on every tile and one code in the middle of the wall: all an app needs
of the hooks, with the defaults of the rest (its code opens the core's page for it)."""

from __future__ import annotations

from pathlib import Path

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp, static_url
from webapp.engine.wall_state import WallState
from webapp.tags.registry import TagSpec
from webapp.web.context import AppContext


class MinimalApp(WallApp):
    name = "minimal"
    layers = (f"{static_url('minimal')}/sun.js",)
    static = Path(__file__).parent / "static"

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        if state.app != self.name:
            return []
        stage = wall.stage
        middle = (stage.x + stage.width / 2, stage.y + stage.height / 2)
        return [TagSpec(name="sun", label="The sun", app=self.name, action="look", anchor=middle)]
