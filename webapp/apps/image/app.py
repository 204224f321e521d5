"""The image app as a wall app: an instructor's image filling the wall's stage, panned
and zoomed with the core's view, with a code on a pin at each of its hotspots; its
hotspots are the places where instructors may stand codes of their own."""

from __future__ import annotations

from pathlib import Path

import click
from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps.hooks import Export, Scan, WallApp, static_url
from webapp.apps.image import commands, pages, routes
from webapp.apps.image.hotspots import Hotspot, hotspots, wall_points
from webapp.apps.image.library import ImageLibrary
from webapp.apps.image.questions import (
    asked,
    fresh_orders,
    hotspot_tag,
    numbers,
    quiz_of,
    round_on_wall,
)
from webapp.apps.image.state import APP, ImageState
from webapp.classes.roll import ClassSession
from webapp.engine.wall_state import AppState, WallState
from webapp.publishing.publication import Publication
from webapp.tags.registry import Place, TagSpec, anchored_code_side_mm
from webapp.web.context import AppContext

FOLDER = Path(__file__).parent
PIN_CLEARANCE_OF_CODE = 0.75
"""The square kept free around a hotspot, in codes' sides: its code stands beside the
point, on a pin, never over it (as the brain's pins)."""


def pin_clearance(context: AppContext, wall: Wall) -> float:
    """The half-side of the square kept free around a hotspot on ``wall``, in mm."""
    return PIN_CLEARANCE_OF_CODE * anchored_code_side_mm(context.base_url, wall)


class ImageApp(ImageLibrary, WallApp):
    """The image app's :class:`~webapp.apps.hooks.WallApp`: its store with what the
    core calls."""

    name: str = APP
    state: type[AppState] | None = ImageState
    layers: tuple[str, ...] = (f"{static_url(APP)}/image.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """Coming on a wall that never chose an image, or whose image was removed while
        another app was up, it shows the newest one (the one just added, as a rule)."""
        store = self.store(context.settings)
        slot = ImageState.of(state)
        if slot.image is not None and store.holds(slot.image):
            return state
        newest = store.images()
        return slot.model_copy(update={"image": newest[0].id if newest else None}).put(state)

    def _shown(self, context: AppContext, state: WallState) -> tuple[str, list[Hotspot]] | None:
        """The image on the wall and its hotspots (None: the app or an image is not up)."""
        image_id = ImageState.of(state).image
        if state.app != APP or image_id is None:
            return None
        try:
            return image_id, hotspots(self.store(context.settings), image_id)
        except KeyError:
            return None

    def _in_view(
        self, context: AppContext, wall: Wall, state: WallState
    ) -> tuple[str, list[Hotspot], dict[str, tuple[float, float]]] | None:
        """The image on the wall, its hotspots and where those the wall shows stand in
        the current view (None: the app or an image is not up, or it has no hotspots)."""
        shown = self._shown(context, state)
        if shown is None or not shown[1]:
            return None
        image_id, spots = shown
        manifest = self.store(context.settings).get(image_id)
        return image_id, spots, wall_points(manifest, spots, wall, state.view)

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """One code per hotspot the wall shows in the current view, anchored at its
        point, kept clear of it so it stands beside it on a pin; named by the round
        on the wall (a new round: new codes) and, in it, numbered by the round."""
        in_view = self._in_view(context, wall, state)
        if in_view is None:
            return []
        image_id, spots, points = in_view
        quiz_round = round_on_wall(context, wall.id, state)
        numbered = numbers(quiz_round, image_id, spots) if quiz_round is not None else {}
        round_number = quiz_round.number if quiz_round is not None else None
        clear = pin_clearance(context, wall)
        return [
            TagSpec(
                name=hotspot_tag(spot.id, round_number),
                # a question's label is its number: the title may give the answer away
                label=f"Question {numbered[spot.id]}" if spot.id in numbered else spot.title,
                app=APP,
                action="hotspot",
                params={"image": image_id, "hotspot": spot.id, "round": round_number},
                anchor=points[spot.id],
                clear_mm=clear,
                priority=-1 - rank,  # placed in the order they were added
            )
            for rank, spot in enumerate(spots)
            if spot.id in points
        ]

    def places(self, context: AppContext, wall: Wall, state: WallState) -> list[Place]:
        """The hotspots in view (of this image: another image's are other places), kept
        clear as their own codes keep them: a code of one's own stands beside the point
        too, never over it."""
        in_view = self._in_view(context, wall, state)
        if in_view is None:
            return []
        image_id, spots, points = in_view
        clear = pin_clearance(context, wall)
        return [
            Place(
                app=APP,
                id=f"{image_id}/{spot.id}",
                label=f"hotspot {spot.title}",
                anchor=points[spot.id],
                clear_mm=clear,
            )
            for spot in spots
            if spot.id in points
        ]

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        """A class whose image asks questions starts on a fresh round (new numbers and
        codes: last class's students cannot bring their answers)."""
        shown = self._shown(context, state)
        if shown is None or not asked(shown[1]):
            return state
        image_id, spots = shown
        started = quiz_of(context).start_round(wall.id, f"app:{APP}", fresh_orders(image_id, spots))
        return ImageState.of(state).later_round(started.number).put(state)

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """The round running closes as the class ends: its students see the answers."""
        quiz_round = round_on_wall(context, wall.id, state)
        if quiz_round is not None and quiz_round.open:
            quiz_of(context).close_round(wall.id, quiz_round.number, f"app:{APP}")
        return state

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        """The answers of every round the class ran, one CSV each."""
        return [
            Export(
                f"Round {number} answers (CSV)",
                f"/api/apps/image/walls/{wall.id}/answers.csv?round={number}",
            )
            for number in quiz_of(context).rounds_during(wall.id, held)
        ]

    async def on_scan(self, scan: Scan) -> Response:
        person = await scan.person()
        return await pages.hotspot_page(scan.request, scan.context, scan.wall, scan.tag, person)

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        """A hotspot's code still opens its page when the view moved on (its question
        may still be answered in its round); an earlier round's says so."""
        if scan.tag.action != "hotspot":
            return None
        return await self.on_scan(scan)

    async def publication(self, scan: Scan) -> Publication | None:
        person = await scan.person()
        return await pages.publication(scan.context, scan.wall, scan.tag, person)

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "image/panel.html"

    def router(self) -> APIRouter | None:
        return routes.router

    def commands(self) -> list[click.Command]:
        return [commands.image]
