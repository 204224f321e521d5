"""Wall applications: each declares its tags and answers the scans of them.

An app is a small plug-in: the core resolves a scanned code to its tag and hands the
scan to the app named on the tag, which returns the phone page. Adding an app means
adding a module here and listing it in :func:`builtin_apps`; the core knows nothing
app-specific. An app extends the dashboard with a panel (``dashboard_panel``), the
public screen with what its pages publish (``publication``) and the server with its
own pages and API (``router``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from fastapi import APIRouter, Request, Response
from fastapi.concurrency import run_in_threadpool

from wall_client.layout import Wall
from webapp.models import TagRecord
from webapp.people import Person
from webapp.publishing import Publication
from webapp.tags import TagSpec, declare, layout_for
from webapp.visitors import Visitor
from webapp.wall_state import Change, WallState, read_state

if TYPE_CHECKING:
    from webapp.services import Services

PLACING_FIELDS = ("app", "view", "dataset", "volume", "tag_set", "quiz_round")
"""State fields that decide which codes stand where: changing one declares the app's
tags again and places the set shown."""


@dataclass(frozen=True)
class Scan:
    """A resolved scan, as an app's handler receives it."""

    request: Request
    services: Services
    wall: Wall
    tag: TagRecord
    visitor: Visitor
    address: str
    subject: str | None = None  # what the page shows when not the tag itself (an index pick)

    async def person(self) -> Person:
        """Who scanned: role, user group, information class (loaded when an app asks)."""
        from webapp.deps import get_person

        return await get_person(self.request, self.services, self.address)


SHARED_LAYERS = ("/static/js/codes.js", "/static/js/balloons.js")
"""The scene's layers drawn over every app's: the placed codes with their pins, and
description balloons."""


class WallApp(Protocol):
    name: str
    default_tag_set: str | None  # the set shown when the app comes on the wall
    layers: tuple[str, ...]
    """The JS modules that draw the app's scene on tiles and the overview, bottom first,
    under :data:`SHARED_LAYERS` (each exports ``createLayer``: ``static/js/layers.js``)."""

    def settle(self, services: Services, wall: Wall, state: WallState) -> WallState:
        """The state as the app needs it when it comes on ``wall`` (say, the data set
        it shows); called in a worker thread, at start too."""
        ...

    def leave(self, state: WallState) -> WallState:
        """The state without what only this app shows (say, its volume), as another app
        comes on the wall: a scene shows only its own app's layers."""
        ...

    def declare_tags(self, services: Services, wall: Wall, state: WallState) -> list[TagSpec]:
        """The named tags the app needs on ``wall`` in ``state`` (declared at every
        start, and again whenever one of :data:`PLACING_FIELDS` changes)."""
        ...

    async def on_scan(self, scan: Scan) -> Response:
        """The phone page for a scan of one of the app's tags."""
        ...

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        """The phone page for a scan of one of the app's tags that does not work now
        (switched off, expired, or of a set not on the wall; ``problem`` says which),
        or None for the core's "no longer in use" page. An app whose codes change as
        it runs tells the phone what became of the thing it scanned."""
        ...

    async def publication(self, scan: Scan) -> Publication | None:
        """What the page of ``scan`` publishes to the public screen (None: nothing).

        Called when the phone presses the Publish button at the bottom of that page;
        the content is built again on the server, never taken from the phone.
        """
        ...

    def dashboard_panel(self, wall: Wall) -> str | None:
        """The template of the app's dashboard panel (None: no panel).

        The dashboard includes it inside its own page with ``wall`` in the context;
        panel scripts are plain modules under ``static/js/`` listed in the template.
        """
        ...

    def router(self) -> APIRouter | None:
        """The app's own pages and API (None: it has none)."""
        ...


async def change_state(
    services: Services, wall: Wall, update: Callable[[WallState], WallState]
) -> Change | None:
    """Change a wall's state, moving its codes with the scene.

    When the change touches what codes are anchored to (:data:`PLACING_FIELDS`), the
    app on the wall declares its tags for the new state and they are placed before
    the change commits, so the new codes arrive in the same swap as the new scene.
    A change of app also puts up that app's tag set.
    """
    async with services.hub.placing(wall.id):
        _, current = await run_in_threadpool(read_state, services.db, wall.id)
        target = update(current)
        if all(getattr(target, f) == getattr(current, f) for f in PLACING_FIELDS):
            return await services.hub.change_state(wall.id, update)
        app = services.apps.get(target.app)
        leaving = services.apps.get(current.app) if current.app != target.app else None
        tag_set = target.tag_set
        settled: dict[str, Any] = {}
        if target.app != current.app:
            ready = leaving.leave(target) if leaving is not None else target
            if app is not None:
                tag_set = app.default_tag_set
                ready = await run_in_threadpool(app.settle, services, wall, ready)
            settled = {
                name: getattr(ready, name)
                for name in WallState.model_fields
                if getattr(ready, name) != getattr(target, name)
            }
            target = ready
        apps = [a for a in (leaving, app) if a is not None]
        layout_id = await run_in_threadpool(_place_for, services, wall, apps, target, tag_set)
        placed = {**settled, "tag_set": tag_set, "tag_layout": layout_id}

        def with_codes(state: WallState) -> WallState:
            return update(state).model_copy(update=placed)

        return await services.hub.change_state(wall.id, with_codes)


def layer_stacks(apps: dict[str, WallApp]) -> dict[str, Any]:
    """What pages that draw the scene load (``static/js/layers.js``): each app's layers
    and the shared ones."""
    return {"apps": {name: list(app.layers) for name, app in apps.items()}, "shared": SHARED_LAYERS}


def _place_for(
    services: Services, wall: Wall, apps: list[WallApp], state: WallState, tag_set: str | None
) -> int:
    """Declare the tags of ``apps`` (the one leaving the wall too) for ``state``, then
    place ``tag_set``; returns the layout's id."""
    for app in apps:
        declare(services.db, wall.id, app.name, app.declare_tags(services, wall, state))
    services.codes.forget()
    return layout_for(services.db, wall, tag_set, services.base_url)


def builtin_apps() -> dict[str, WallApp]:
    from webapp.apps.brain_atlas import BrainApp
    from webapp.apps.census_map import CensusApp
    from webapp.apps.core import CoreApp
    from webapp.apps.pattern import PatternApp

    apps: tuple[WallApp, ...] = (CoreApp(), PatternApp(), CensusApp(), BrainApp())
    return {app.name: app for app in apps}
