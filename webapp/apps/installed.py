"""What the core asks of the installed apps together: their layers, the state keys they
name heavy or placing, the places the wall shows, the apps a wall can show."""

from __future__ import annotations

from typing import Any

from wall_client.layout import Wall
from webapp.apps.hooks import DEFAULT_MODE, WallApp
from webapp.engine.wall_state import CORE_HEAVY_KEYS, CORE_PLACING_KEYS, WallState
from webapp.tags.registry import Place
from webapp.web.context import AppContext

SHARED_LAYERS = ("/static/js/pointers.js", "/static/js/codes.js", "/static/js/balloons.js")
"""The scene's layers drawn over every app's: the balloons' pointers, the placed codes
with their pins, and the balloons' boxes."""

REGISTRATION = "core"
"""The app of the registration codes: on every wall, never the app a wall shows."""


def layer_stacks(apps: dict[str, WallApp]) -> dict[str, Any]:
    """What pages that draw the scene load (``static/js/layers.js``): each app's layers
    and the shared ones."""
    return {"apps": {name: list(app.layers) for name, app in apps.items()}, "shared": SHARED_LAYERS}


def heavy_keys(apps: dict[str, WallApp]) -> frozenset[str]:
    """The state keys whose change tiles prepare for: the core's and every app's."""
    return CORE_HEAVY_KEYS.union(*(app.state.keys()[0] for app in apps.values() if app.state))


def placing_keys(apps: dict[str, WallApp]) -> frozenset[str]:
    """The state keys that move codes: the core's and every app's."""
    return CORE_PLACING_KEYS.union(*(app.state.keys()[1] for app in apps.values() if app.state))


def places_shown(
    apps: dict[str, WallApp], context: AppContext, wall: Wall, state: WallState
) -> list[Place]:
    """The places the wall shows now: those of the app on it (none when that app is not
    installed)."""
    app = apps.get(state.app)
    return app.places(context, wall, state) if app is not None else []


def wall_apps(apps: dict[str, WallApp]) -> dict[str, WallApp]:
    """The apps a wall can show: every installed app but the registration codes'."""
    return {name: app for name, app in apps.items() if name != REGISTRATION}


def modes_of(app: WallApp) -> tuple[str, ...]:
    """The modes the wall state may be in while ``app`` is on the wall."""
    return app.modes or (DEFAULT_MODE,)
