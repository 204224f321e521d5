"""The apps that ship with tagwall: the one list the app factory registers."""

from __future__ import annotations

from webapp.apps.brain_atlas.app import BrainApp
from webapp.apps.census_map.app import CensusApp
from webapp.apps.contract import WallApp
from webapp.apps.pattern.app import PatternApp
from webapp.apps.registration.app import CoreApp


def builtin_apps() -> dict[str, WallApp]:
    apps: tuple[WallApp, ...] = (CoreApp(), PatternApp(), CensusApp(), BrainApp())
    return {app.name: app for app in apps}
