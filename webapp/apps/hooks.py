"""The hooks of a tagwall app: every one listed here, with its default.

An app is a plug-in (found through the ``tagwall.apps`` entry points,
:mod:`webapp.apps.discovery`): a subclass of :class:`WallApp` that sets its ``name`` and
overrides only the hooks it uses. Every hook is optional; what an app leaves out
behaves as documented on the hook here, the one place defaults live (as pluggy's
``hookspecs`` are for pytest and datasette). At start the server checks each app
against this module (:func:`webapp.apps.discovery.check_app`): a hook overridden with
another signature (sync for async, other parameters), a slot or route outside the app's
own name, stops the server with one line naming the distribution, the app and the hook.

The core calls the hooks; an app is handed an :class:`~webapp.web.context.AppContext`,
never the server itself. See docs/apps.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import click
from fastapi import APIRouter, Request, Response

from wall_client.layout import Wall
from webapp.classes.roll import ClassSession
from webapp.core.settings import Settings
from webapp.database.models import TagRecord
from webapp.engine.wall_state import AppState, WallState
from webapp.people.person import Person, person_of
from webapp.people.visitors import Visitor
from webapp.publishing.publication import Publication
from webapp.tags.registry import Place, TagSpec
from webapp.web.context import AppContext
from webapp.web.templating import render

DEFAULT_MODE = "default"
"""The mode of the wall state while the app on it has no modes of its own."""


@dataclass(frozen=True)
class Scan:
    """A resolved scan, as an app's handler receives it: the phone's ``request``, the
    ``context``, the ``wall`` and ``tag`` scanned (``tag.app``, ``tag.action`` and
    ``tag.params`` are what the app declared), the phone's ``visitor`` and client
    ``address``, and ``subject``, what the page shows when it is not the tag itself
    (an entry picked from a cluster code's list)."""

    request: Request
    context: AppContext
    wall: Wall
    tag: TagRecord
    visitor: Visitor
    address: str
    subject: str | None = None

    async def person(self) -> Person:
        """Who scanned: role, user group, information class (read when an app asks)."""
        context = self.context
        return await person_of(
            self.request, context.db, context.settings, self.address, context.address_rules
        )


@dataclass(frozen=True)
class ContentCheck:
    """What an app's check of its part of the content folder found: the ``folder``
    checked, a one-line ``summary`` of what is there, and one line per problem (the
    file and field each, as an editor fixes them)."""

    folder: Path
    summary: str
    problems: list[str]


@dataclass(frozen=True)
class Export:
    """A download of what a class produced (the answers of a quiz round, as CSV)."""

    label: str
    url: str


class WallApp:
    """An app on tagwall's walls. Subclass it, set :attr:`name`, override what you use.

    Attributes are read once, as the app is loaded; hooks are called by the core. Hooks
    marked *worker thread* may block (they read files, the database); the ``async``
    ones run on the event loop and must not.
    """

    name: str = ""
    """The app's name, its entry point's: in tags, URLs, its slot and its tables."""

    default_tag_set: str | None = None
    """The tag set shown when the app comes on a wall (None: only codes without a set)."""

    state: type[AppState] | None = None
    """The model of the app's slot of the wall state (its ``app`` is the app's name;
    None: the app keeps nothing there)."""

    layers: tuple[str, ...] = ()
    """The browser modules that draw the app's scene on tiles and the overview, bottom
    first, under the codes and balloons every app shares (each exports
    ``createLayer``: ``static/js/layers.js``)."""

    templates: Path | None = None
    """The folder of the app's page templates, each under a folder of the app's name
    (``census/tract.html``), so apps never shadow the core's or each other's."""

    static: Path | None = None
    """The folder of the app's browser modules, served at ``/static/apps/<name>/``."""

    migrations: Path | None = None
    """The folder of the app's Alembic revisions, for tables of its own (named
    ``<name>_...``): a history of their own (the first revision's ``down_revision`` is
    None), recorded in ``alembic_version_<name>``; they run after the core's (``tagwall
    db upgrade``, ``tagwall serve``) and go down before them."""

    modes: tuple[str, ...] = ()
    """The app's modes, the first its default (the brain atlas: ``quiz``, ``tutor``;
    none: the wall state's mode stays ``default``)."""

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """The state as the app needs it when it comes on ``wall`` (a data set, a
        volume, a round), at start too. It comes on by a switch at the default view
        (the whole stage) unless the switch names one; it may set its own. Worker
        thread. Default: the state as it is."""
        return state

    def leave(self, state: WallState) -> WallState:
        """The state without what only this app shows (its volume), as another app
        comes on the wall. Default: the state as it is."""
        return state

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """The named tags the app needs on ``wall`` in ``state``: declared at every
        start and whenever a placing key (the core's or an app's) changes; a name keeps
        its code. Each tag's ``app`` is the app's name. Worker thread. Default: none."""
        return []

    def places(self, context: AppContext, wall: Wall, state: WallState) -> list[Place]:
        """The named points of the app's material that ``wall`` shows now (an image's
        hotspots in view), where an instructor may stand a code of their own; such a
        code follows its place and leaves the wall while the place is not shown. Asked
        of the app on the wall at every placement, in a worker thread. Default: none."""
        return []

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        """The tags the app stands on the designated screens (registration, menu,
        public) while it is on ``wall``, as many as it ever puts there, known without a
        running server: ``tagwall config check``, ``serve`` and the dashboard check they
        fit. Default: none."""
        return []

    def switch_mode(
        self, context: AppContext, wall: Wall, state: WallState, mode: str
    ) -> WallState:
        """The state with the app in ``mode`` (one of :attr:`modes`, checked by the
        core): what the mode needs besides (the brain's quiz mode opens a round, its
        tutor mode closes the one running). Every change of mode comes here: the
        dashboard's, the state API's and the app's own. Worker thread. Default: the
        mode set, nothing else."""
        return state.model_copy(update={"mode": mode})

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        """The state a class starts from, the app on the wall at the whole stage,
        without balloons or a publication: its first view and, in ``mode`` (one of
        :attr:`modes`, None for an app without modes), what a class needs fresh (a new
        quiz round). Worker thread. Default: the state as it is."""
        return state

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """What ends with a class (its quiz round closes). Worker thread. Default: the
        state as it is."""
        return state

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        """Downloads of what the class ``held`` produced. Worker thread. Default: none."""
        return []

    async def on_scan(self, scan: Scan) -> Response:
        """The phone page of a scan of one of the app's tags. Default: a page with the
        code's label, for an app whose codes only mark things on the wall."""
        return render(scan.request, "scanned.html", wall=scan.wall, tag=scan.tag, app=self.name)

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        """The phone page of a scan of one of the app's tags that does not work now
        (switched off, expired, or of a set not on the wall; ``problem`` says which):
        an app whose codes change as it runs tells the phone what became of the thing
        it scanned. Default: None, the core's "no longer in use" page."""
        return None

    async def publication(self, scan: Scan) -> Publication | None:
        """What the page of ``scan`` publishes to the public screen when the phone
        presses Publish: built again on the server, never taken from the phone.
        Default: None (the page has no Publish button)."""
        return None

    def dashboard_panel(self, wall: Wall) -> str | None:
        """The template of the app's dashboard panel, shown while the app is on
        ``wall``; it is included in the dashboard with ``wall`` in its context, and
        its scripts are modules of the app's ``static`` folder. Default: no panel."""
        return None

    def check_content(self, settings: Settings) -> ContentCheck | None:
        """Check the app's part of the content folder (its subfolder,
        ``settings.content_folder(<its folder name>)``) as ``tagwall content check``
        does before a term: every problem found, not the first. Default: None (the app
        reads no content of its own)."""
        return None

    def router(self) -> APIRouter | None:
        """The app's own pages and API, every path under ``/apps/<name>/`` or
        ``/api/apps/<name>/`` (checked at start). Default: none."""
        return None

    def commands(self) -> list[click.Command]:
        """The app's ``tagwall`` commands (documented in docs/cli.md like the core's).
        Default: none."""
        return []


HOOKS: tuple[str, ...] = tuple(
    name for name, value in vars(WallApp).items() if callable(value) and not name.startswith("_")
)
"""Every hook's name, in the order above."""

ATTRIBUTES: tuple[str, ...] = tuple(
    name for name in WallApp.__annotations__ if not name.startswith("_")
)
"""Every attribute an app may set, in the order above."""


VOLUME_LAYER = "/static/js/volume.js"
"""The core's layer drawing the wall state's ``volume``: an app that shows volumes lists
it in its ``layers`` (and the dashboard shows its Volume box while the app is up)."""


def static_url(app_name: str) -> str:
    """Where an app's ``static`` folder is served."""
    return f"/static/apps/{app_name}"


def route_prefixes(app_name: str) -> tuple[str, str]:
    """Where an app's routes live: its pages under the first, its API under the second.
    Nothing of the core's is there, so no app answers a path of the core's."""
    return f"/apps/{app_name}/", f"/api/apps/{app_name}/"
