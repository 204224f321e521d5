"""The contract between tagwall and its apps: what an app is and what it is given.

An app is a plug-in: the core resolves a scanned code to its tag and hands the scan to
the app named on the tag, which returns the phone page. Apps are found through the
``tagwall.apps`` entry-point group (:mod:`webapp.apps.discovery`), the built-in ones
too, so a new app is a package of its own and touches no file of tagwall. An app owns
all of its parts in its package and contributes them here: its slot of the wall state
(``state``), its scene layers (``layers``), page templates (``templates``), browser
modules (``static``), a dashboard panel (``dashboard_panel``), what its pages publish to
the public screen (``publication``), the places of its material where instructors may
stand codes of their own (``places``), its own pages and API (``router``) and its
``tagwall`` commands (``commands``). It is handed an :class:`AppContext`, never the
server itself. See docs/apps.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import click
from fastapi import APIRouter, Request, Response

from wall_client.layout import Wall
from webapp.classes.roll import ClassSession
from webapp.database.models import TagRecord
from webapp.engine.wall_state import CORE_HEAVY_KEYS, CORE_PLACING_KEYS, AppState, WallState
from webapp.people.person import Person, person_of
from webapp.people.visitors import Visitor
from webapp.publishing.publication import Publication
from webapp.tags.registry import Place, TagSpec
from webapp.web.context import AppContext


@dataclass(frozen=True)
class Scan:
    """A resolved scan, as an app's handler receives it."""

    request: Request
    context: AppContext
    wall: Wall
    tag: TagRecord
    visitor: Visitor
    address: str
    subject: str | None = None  # what the page shows when not the tag itself (an index pick)

    async def person(self) -> Person:
        """Who scanned: role, user group, information class (loaded when an app asks)."""
        context = self.context
        return await person_of(
            self.request, context.db, context.settings, self.address, context.address_rules
        )


@dataclass(frozen=True)
class Export:
    """A download of what a class produced (the answers of a quiz round, as CSV)."""

    label: str
    url: str


class WithoutClassSteps:
    """Mixed into an app that does nothing of its own as a class starts and ends (no
    modes, nothing to close, nothing to download): the core's fresh start is all."""

    class_modes: tuple[str, ...] = ()

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        return state

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        return state

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        return []


class WithoutPlaces:
    """Mixed into an app whose material has no places where an instructor may stand a
    code of their own (a map of tracts, a volume): such codes stand at points of the
    wall while it is up."""

    def places(self, context: AppContext, wall: Wall, state: WallState) -> list[Place]:
        return []


SHARED_LAYERS = ("/static/js/pointers.js", "/static/js/codes.js", "/static/js/balloons.js")
"""The scene's layers drawn over every app's: the balloons' pointers, the placed codes
with their pins, and the balloons' boxes."""


class WallApp(Protocol):
    name: str
    default_tag_set: str | None  # the set shown when the app comes on the wall
    state: type[AppState] | None
    """The model of the app's slot of the wall state (None: it keeps nothing there)."""
    layers: tuple[str, ...]
    """The JS modules that draw the app's scene on tiles and the overview, bottom first,
    under :data:`SHARED_LAYERS` (each exports ``createLayer``: ``static/js/layers.js``)."""
    templates: Path | None
    """The folder of the app's page templates, each under the app's own prefix
    (``census/tract.html``), so apps never shadow the core's or each other's."""
    static: Path | None
    """The folder of the app's browser modules, served at :func:`static_url`."""
    class_modes: tuple[str, ...]
    """The modes a class can start the app in, the first the default (the brain atlas:
    ``quiz``, ``tutor``; none for an app without modes)."""

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """The state as the app needs it when it comes on ``wall`` (say, the data set
        it shows); called in a worker thread, at start too."""
        ...

    def leave(self, state: WallState) -> WallState:
        """The state without what only this app shows (say, its volume), as another app
        comes on the wall: a scene shows only its own app's layers."""
        ...

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """The named tags the app needs on ``wall`` in ``state`` (declared at every
        start, and again whenever a placing key, the core's or an app's, changes)."""
        ...

    def places(self, context: AppContext, wall: Wall, state: WallState) -> list[Place]:
        """The named points of the app's material that ``wall`` shows now in ``state``
        (an image's hotspots in view), where an instructor may stand a code of their own:
        such a code follows its place as the view moves and leaves the wall while the
        place is not shown (none: an empty list, :class:`WithoutPlaces`). Asked of the
        app on the wall at every placement, in a worker thread."""
        ...

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        """The tags the app stands on the designated screens (registration, menu,
        public) while it is on ``wall``, as many as it ever puts there: known without a
        running server, so ``tagwall config check`` and the dashboard can tell before
        class whether they fit (:mod:`webapp.apps.fitting`)."""
        ...

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        """The state a class starts from, with the app on the wall: its first view and,
        in ``mode`` (one of :attr:`class_modes`), what a class needs fresh (a new quiz
        round). Called in a worker thread."""
        ...

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """What ends with a class (its quiz round closes, so students see the names);
        called in a worker thread."""
        ...

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        """Downloads of what the class ``held`` produced (none: an empty list)."""
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

    def commands(self) -> list[click.Command]:
        """The app's ``tagwall`` commands (documented in docs/cli.md like the core's)."""
        ...


def static_url(app_name: str) -> str:
    """Where an app's ``static`` folder is served."""
    return f"/static/apps/{app_name}"


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


REGISTRATION = "core"
"""The app of the registration codes: on every wall, never the app a wall shows."""


def wall_apps(apps: dict[str, WallApp]) -> dict[str, WallApp]:
    """The apps a wall can show: every installed app but the registration codes'."""
    return {name: app for name, app in apps.items() if name != REGISTRATION}
