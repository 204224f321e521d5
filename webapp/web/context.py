"""What an app is given of the running server: a narrow protocol, not the server itself.

Apps (and the public screen) are written against :class:`AppContext`; the server's
``Services`` implements it. An app reaches the database, the settings, the walls and
the codes through it, and changes a wall only through its door (:meth:`change_wall`,
:meth:`plan_change`), so no app imports the layers above it.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Protocol

from wall_client.layout import Wall
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import TagLayoutRecord
from webapp.engine.wall_state import Change, WallState
from webapp.people.addresses import AddressRules
from webapp.people.ratelimit import WallAction
from webapp.people.visitors import Visitor
from webapp.tags.scanning import CodeDirectory
from webapp.volume.catalog import VolumeCatalog

Update = Callable[[WallState], WallState]
"""A change as a function of the state: applied to the state as it is at commit."""
Plan = Callable[[WallState], Awaitable[Update]]
"""A change that looks at the wall first: the current state in, the update out."""


class AppContext(Protocol):
    settings: Settings
    db: Database
    walls: dict[str, Wall]
    volumes: VolumeCatalog
    codes: CodeDirectory
    address_rules: AddressRules

    @property
    def base_url(self) -> str:
        """Where phones reach this server: the base of every URL code."""
        ...

    def layout(self, wall_id: str, layout_id: int | None) -> TagLayoutRecord | None:
        """The wall's placed codes ``layout_id`` (None: no such layout of this wall)."""
        ...

    async def action_allowed(
        self, kind: WallAction, visitor: Visitor, address: str, wall_id: str = ""
    ) -> float | None:
        """None when this visitor may do ``kind`` now, else the seconds to wait."""
        ...

    async def state(self, wall: Wall) -> WallState:
        """The wall's state now, for a handler on the event loop (a short read that
        holds no thread on SQLite and does not hold the loop on a database server)."""
        ...

    @property
    def installed(self) -> frozenset[str]:
        """The names of the apps loaded: only their codes stand on the walls."""
        ...

    def app(self, name: str) -> object:
        """The installed app ``name`` (an app finds its own object this way: its pages
        and routes check its type, so no module names the app's class by a cast)."""
        ...

    async def change_wall(
        self, wall: Wall, update: Update, *, replace_codes: bool = False
    ) -> Change | None:
        """Change ``wall`` by ``update`` through the one door; None when nothing changed."""
        ...

    async def plan_change(
        self, wall: Wall, plan: Plan, *, replace_codes: bool = False
    ) -> Change | None:
        """Like :meth:`change_wall`, for a change that must look at the wall first."""
        ...

    async def shown_at(self, wall: Wall, version: int) -> int | None:
        """The wall clock's instant (server ms) from which every tile of ``wall`` shows
        ``version`` (a heavy change's swap comes once the tiles have prepared it),
        waiting for it; None when it was not heard in the time a swap may take."""
        ...


class ServerContext(AppContext, Protocol):
    """What the request checks of :mod:`webapp.web.deps` need beyond an app's context:
    the secrets that tokens are checked against."""

    @property
    def secret(self) -> str: ...

    @property
    def operator_token(self) -> str: ...

    def tile_token(self, wall_id: str) -> str: ...
