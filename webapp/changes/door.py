"""The one door for wall-state changes.

Everything that changes a wall — an operator's patch, a phone's toggle or balloon, a
publication, a tag-set switch, a tag issued or patched, the start of a server — goes
through here, and nothing else calls the hub's :meth:`~webapp.engine.hub.WallHub.commit`.
A change:

1. runs under the wall's placing lock, so two changes of one wall never interleave
   (a tag-set switch racing an app switch cannot leave codes that belong to another
   view);
2. lets an app leaving the wall take what only it shows (its volume) and an app
   coming on start from the default view, settle and bring its own tag set;
3. when it moves what codes stand on (the core's placing keys and each app's), has
   the apps on the wall declare their tags for the new state, stands the codes issued
   at places of the app's material where those places are now (or nowhere, while the
   wall does not show them) and places the set shown, so the codes arrive in the same
   swap as the scene;
4. drops the cached code look-ups when tags were declared or placed;
5. commits (bumping the version) and publishes to the tiles, through the hub.

The door stands above the engine, the tags and the apps' hooks: it calls apps'
``settle``, ``leave``, ``declare_tags`` and ``places`` with the context apps are given.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp
from webapp.apps.installed import places_shown, placing_keys, wall_apps
from webapp.engine.hub import WallHub
from webapp.engine.wall_state import (
    Change,
    View,
    WallState,
    differing_fields,
    differing_keys,
    read_state,
)
from webapp.tags.registry import active_tags_per_app, declare, layout_for, stand_at_places
from webapp.web.context import AppContext, Plan, Update

log = logging.getLogger(__name__)


def unchanged(state: WallState) -> WallState:
    return state


class WallDoor:
    """The door of this server's walls: ``context`` is what apps are handed, ``apps``
    every installed app (the ``core`` registration codes among them), ``first_app`` the
    app a wall shows before anyone chose one."""

    def __init__(
        self,
        context: AppContext,
        hub: WallHub,
        apps: dict[str, WallApp],
        first_app: str,
        base_url: Callable[[], str],
    ) -> None:
        self.context = context
        self.hub = hub
        self.apps = apps
        self.first_app = first_app
        self.base_url = base_url
        self.placing_keys = placing_keys(apps)

    async def change(
        self, wall: Wall, update: Update, *, replace_codes: bool = False
    ) -> Change | None:
        """Change ``wall`` by ``update``; None when that changes nothing.

        ``replace_codes`` places the shown set again even when no placing key changes
        (after a tag of the wall was issued or patched).
        """

        async def plan(_current: WallState) -> Update:
            return update

        return await self.plan(wall, plan, replace_codes=replace_codes)

    async def plan(self, wall: Wall, plan: Plan, *, replace_codes: bool = False) -> Change | None:
        """Like :meth:`change`, for a change that must look at the wall first (where a
        balloon fits among the codes shown): ``plan`` gets the current state, with the
        wall held, and returns the update."""
        async with self.hub.placing(wall.id):
            _, current = await self.hub.run_sync(read_state, self.context.db, wall.id)
            update = await plan(current)
            target = update(current)
            if not (replace_codes or self._moves_codes(current, target)):
                return await self.hub.commit(wall.id, update)
            placed = await self.hub.run_sync(self._place_codes, wall, current, target)
            return await self.hub.commit(
                wall.id, lambda state: update(state).model_copy(update=placed)
            )

    async def open(self, wall: Wall) -> Change | None:
        """Bring a wall up at server start: the first app on a wall that shows none (or an
        app no longer installed),
        settle the app it shows, declare every app's tags and put the wall's tag set up.

        Idempotent: codes stay as they were and an unchanged set is not placed again, so
        every server process of a wall may do this at start.
        """
        async with self.hub.placing(wall.id):
            _, current = await self.hub.run_sync(read_state, self.context.db, wall.id)
            fields = await self.hub.run_sync(self._opening_fields, wall, current)
            return await self.hub.commit(wall.id, lambda state: state.model_copy(update=fields))

    def _moves_codes(self, current: WallState, target: WallState) -> bool:
        return bool(self.placing_keys & differing_keys(current, target))

    def _place_codes(self, wall: Wall, current: WallState, target: WallState) -> dict[str, Any]:
        """The fields that put the right codes up for ``target``: what the app coming on
        the wall settles, and the tag set and its layout (runs in a worker thread)."""
        app = self.apps.get(target.app)
        leaving = self.apps.get(current.app) if current.app != target.app else None
        fields: dict[str, Any] = {}
        tag_set = target.tag_set
        if target.app != current.app:
            ready = target
            if target.view == current.view:
                # The app coming on starts from the whole stage (its settle may choose
                # its own view), not from where the app leaving looked; a change that
                # names a view with the app keeps it. Only a switch does this: at
                # start (open) an instructor's pan stays.
                ready = ready.model_copy(update={"view": View()})
            ready = leaving.leave(ready) if leaving is not None else ready
            if app is not None:
                tag_set = app.default_tag_set
                ready = app.settle(self.context, wall, ready)
            fields = differing_fields(ready, target)
            target = ready
        declaring = [a for a in (leaving, app) if a is not None]
        return {**fields, **self._declare_and_place(wall, declaring, target, tag_set)}

    def _opening_fields(self, wall: Wall, current: WallState) -> dict[str, Any]:
        """What a wall's state needs at start (see :meth:`open`)."""
        for gone, count in sorted(active_tags_per_app(self.context.db, wall.id).items()):
            if gone not in self.apps:
                log.info(
                    "app %r is not installed: its %d codes leave wall %r until it is again",
                    gone,
                    count,
                    wall.id,
                )
        state = current
        showable = wall_apps(self.apps)
        arriving = state.app not in showable and self.first_app in showable
        if arriving:  # never shown one, or left on an app no longer installed
            state = state.model_copy(update={"app": self.first_app})
        if (shown := self.apps.get(state.app)) is not None:
            state = shown.settle(self.context, wall, state)
        fields = differing_fields(state, current)
        tag_set = state.tag_set
        if (arriving or not state.tag_layout) and shown is not None:
            tag_set = shown.default_tag_set
        return {**fields, **self._declare_and_place(wall, list(self.apps.values()), state, tag_set)}

    def _declare_and_place(
        self, wall: Wall, apps: list[WallApp], state: WallState, tag_set: str | None
    ) -> dict[str, Any]:
        """Declare the tags of ``apps`` for ``state``, stand the codes issued at places
        where the places are in ``state``, then place ``tag_set``; the scan path's
        cached look-ups are dropped, since codes may have come or gone."""
        db = self.context.db
        for app in apps:
            declare(db, wall.id, app.name, app.declare_tags(self.context, wall, state))
        stand_at_places(db, wall.id, places_shown(self.apps, self.context, wall, state))
        layout_id = layout_for(db, wall, tag_set, self.base_url(), self.apps)
        self.context.codes.forget()
        return {"tag_set": tag_set, "tag_layout": layout_id}
