"""The brain atlas as a wall app: what it shows, which tags it declares, how it answers scans."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps.brain_atlas import pages, routes
from webapp.apps.brain_atlas.atlas import Atlases, group_menu
from webapp.apps.brain_atlas.checks import check_folder
from webapp.apps.brain_atlas.content import atlas_folder
from webapp.apps.brain_atlas.pins import TEMPLATE_FILE, VOLUME
from webapp.apps.brain_atlas.rules import (
    APP,
    MODES,
    TAG_SETS,
    mode_of_class,
    quiz_of,
)
from webapp.apps.brain_atlas.state import BrainState
from webapp.apps.hooks import VOLUME_LAYER, ContentCheck, Export, Scan, WallApp
from webapp.classes.roll import ClassSession
from webapp.core.settings import Settings
from webapp.engine.wall_state import WallState
from webapp.publishing.publication import Block, Publication
from webapp.tags.registry import TagSpec
from webapp.volume.build import build_store, open_source
from webapp.web.context import AppContext

FOLDER = Path(__file__).parent


class BrainApp(Atlases, WallApp):
    """The brain atlas's :class:`~webapp.apps.hooks.WallApp`: the atlas of the content
    folder in use with what the core calls."""

    state = BrainState
    name: str = APP
    default_tag_set: str | None = TAG_SETS["full"]
    layers: tuple[str, ...] = (VOLUME_LAYER,)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"
    modes: tuple[str, ...] = MODES

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """On the wall the brain shows the MNI template (its store built on first use)
        in the first preset view, in quiz mode, unless it is already up. The first time
        it comes on a wall it opens the wall's first round; after that the round on the
        wall stays as the instructor left it, open or closed, whatever restarts: a
        round opens only when an instructor opens one."""
        atlas = self.atlas(context.settings)
        if VOLUME not in context.volumes:
            build_store(
                open_source(atlas.folder / TEMPLATE_FILE),
                context.settings.resolved_volume_dir / VOLUME,
                name=VOLUME,
            )
        update: dict[str, object] = {}
        if state.mode not in MODES:
            update["mode"] = "quiz"
        if state.volume is None or state.volume.volume != VOLUME:
            first = atlas.views[0]
            update["view"] = first.view
            update["volume"] = first.layer(VOLUME)
        settled = state.model_copy(update=update) if update else state
        if BrainState.of(state).quiz_round is None:
            opened = quiz_of(context).open_round(wall.id, f"app:{APP}", atlas.fresh_orders())
            settled = BrainState(quiz_round=opened.number).put(settled)
        return settled

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        return self.atlas(context.settings).declare_tags(context, wall, state)

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        return group_menu()

    def leave(self, state: WallState) -> WallState:
        """The brain's volume goes with it (its quiz round stays for its return)."""
        return state.model_copy(update={"volume": None})

    def switch_mode(
        self, context: AppContext, wall: Wall, state: WallState, mode: str
    ) -> WallState:
        return self.atlas(context.settings).switch_mode(context, wall.id, state, mode, f"app:{APP}")

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        """A class starts at the first preset view; in quiz mode on a fresh round (new
        pin numbers and codes: last class's students cannot bring their answers), in
        tutor mode with no round running (tutor pages name every pin)."""
        atlas = self.atlas(context.settings)
        first = atlas.views[0]
        began = state.model_copy(
            update={"mode": mode_of_class(mode), "view": first.view, "volume": first.layer(VOLUME)}
        )
        by = f"app:{APP}"
        if began.mode == "quiz":
            started = quiz_of(context).start_round(wall.id, by, atlas.fresh_orders())
            return BrainState.of(began).later_round(started.number).put(began)
        self._close_running(context, wall, began, by)
        return began

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """The round running closes as the class ends: its students see the names and
        their results, and no answer counts any more."""
        self._close_running(context, wall, state, f"app:{APP}")
        return state

    def _close_running(self, context: AppContext, wall: Wall, state: WallState, by: str) -> None:
        number = BrainState.of(state).quiz_round
        quiz = quiz_of(context)
        shown = quiz.get_round(wall.id, number) if number is not None else None
        if shown is not None and shown.open:
            quiz.close_round(wall.id, shown.number, by)

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        """The answers of every quiz round the class ran, one CSV each."""
        return [
            Export(
                f"Round {number} answers (CSV)",
                f"/api/apps/brain/walls/{wall.id}/answers.csv?round={number}",
            )
            for number in quiz_of(context).rounds_during(wall.id, held)
        ]

    async def on_scan(self, scan: Scan) -> Response:
        atlas = self.atlas(scan.context.settings)
        if scan.tag.action == "group":
            return await pages.choose_group(atlas, scan)
        person = await scan.person()
        return await pages.pin_page(atlas, scan.request, scan.context, scan.wall, scan.tag, person)

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        """A pin's code still opens its question while its round runs (the view
        turned, or the other set is up: the phone may still answer it); a code of an
        earlier round says that a new round has started."""
        if scan.tag.action != "pin":
            return None
        atlas = self.atlas(scan.context.settings)
        person = await scan.person()
        return await pages.pin_page(atlas, scan.request, scan.context, scan.wall, scan.tag, person)

    async def publication(self, scan: Scan) -> Publication | None:
        """In tutor mode, the region's fuller page (the phone shows its summary); in
        quiz mode nothing, so the public screen never names a pin."""
        if scan.tag.action != "pin":
            return None
        atlas = self.atlas(scan.context.settings)
        region = await pages.tutor_subject(atlas, scan.context, scan.wall, scan.tag)
        if region is None:
            return None
        person = await scan.person()
        found = atlas.tutor_text(region, person.user_group)
        if found is None:
            return None
        _, text = found
        references = [atlas.content.references[r] for r in text.references]
        blocks = [Block(kind="markdown", text=text.text)]
        if references:
            # Citations are Markdown (journal and book titles in italics): a list
            # renders them; plain rows would show the asterisks.
            listed = "\n".join(
                f"{n}. {r.citation}" + (f" <{r.url}>" if r.url else "")
                for n, r in enumerate(references, 1)
            )
            blocks.append(Block(kind="markdown", text=f"**Sources**\n\n{listed}"))
        return Publication(title=region.name, blocks=blocks)

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "brain/panel.html"

    def router(self) -> APIRouter | None:
        return routes.router

    def check_content(self, settings: Settings) -> ContentCheck:
        return check_folder(atlas_folder(settings))
