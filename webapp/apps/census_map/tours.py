"""Tours: a list of views the wall plays in step, each a state change that every tile
applies at the wall clock's instant (a heavy one: the tiles prepare the step's picture,
then all swap together).

The server drives a tour: playing starts a task in the process that was asked, which
changes the wall to each step after the one before has dwelt its ``dwell_s``, counted
from the instant the tiles show it (a step's picture on the globe takes seconds to
prepare, under software GL tens; counted from the change, a step that took longer to
prepare than the next stayed that much less). The wall state says whether a tour
plays and which play (``run``), so the driver ends when it is stopped from any
process, when another play replaces it, when the instructor turns the camera or flies
elsewhere, or when the wall leaves the census map. A task does not survive its
process: a server that starts finds a tour still marked playing and marks it stopped,
saying so (the app's ``settle``)."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable

from wall_client.layout import Wall
from webapp.apps.census_map.actions import shown_census, with_census
from webapp.apps.census_map.maps import CensusMaps
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.state import CensusState, Tour, TourStep
from webapp.engine.wall_state import WallState, now_ms
from webapp.web.context import AppContext

log = logging.getLogger(__name__)

Sleep = Callable[[float], Awaitable[None]]


class NoTour(Exception):
    """The wall has no tour steps to play."""


class TourEnded(Exception):
    """The tour the driver plays was stopped or replaced."""


def at_step(state: WallState, census: CensusState, tour: Tour, index: int) -> WallState:
    """``state`` showing step ``index`` of ``tour``: the wall's view, the globe's camera."""
    step = tour.steps[index]
    shown = census.model_copy(
        update={
            "heading": step.heading,
            "tilt": step.tilt,
            "tour": tour.model_copy(update={"step": index}),
        }
    )
    return with_census(state.model_copy(update={"view": step.view(state.view)}), shown)


async def save_tour(context: AppContext, wall: Wall, steps: list[TourStep]) -> Tour:
    """Keep ``steps`` as the wall's tour (a tour playing stops). Raises
    :class:`MapChanged` when the census map is not on the wall."""
    saved = Tour()

    def keep(state: WallState) -> WallState:
        nonlocal saved
        census = shown_census(state)
        saved = census.tour.stopped("the instructor changed the tour").model_copy(
            update={"steps": steps, "step": 0}
        )
        return census.model_copy(update={"tour": saved}).put(state)

    await context.change_wall(wall, keep)
    return saved


async def play_tour(
    app: CensusMaps, context: AppContext, wall: Wall, sleep: Sleep = asyncio.sleep
) -> Tour:
    """Play the wall's tour from its first step, driven by a task of this process.
    Raises :class:`MapChanged` when the census map is not on the wall and
    :class:`NoTour` when the tour has no steps."""
    started = Tour()

    def start(state: WallState) -> WallState:
        nonlocal started
        census = shown_census(state)
        if not census.tour.steps:
            raise NoTour
        started = census.tour.model_copy(
            update={"playing": True, "run": census.tour.run + 1, "note": ""}
        )
        return at_step(state, census, started, 0)

    change = await context.change_wall(wall, start)
    previous = app.tours.get(wall.id)
    if previous is not None:
        previous.cancel()
    shown = change.version if change is not None else None
    app.tours[wall.id] = asyncio.create_task(drive(context, wall, started.run, shown, sleep))
    return started


async def stop_tour(app: CensusMaps, context: AppContext, wall: Wall) -> Tour:
    """Stop the wall's tour where it is (its driver ends, in whichever process)."""
    stopped = Tour()

    def stop(state: WallState) -> WallState:
        nonlocal stopped
        census = CensusState.of(state)
        stopped = census.tour.stopped("the instructor stopped it")
        return census.model_copy(update={"tour": stopped}).put(state) if state.app == APP else state

    await context.change_wall(wall, stop)
    task = app.tours.pop(wall.id, None)
    if task is not None:
        task.cancel()
    return stopped


async def drive(
    context: AppContext, wall: Wall, run: int, shown: int | None, sleep: Sleep = asyncio.sleep
) -> None:
    """Play on play ``run`` of the wall's tour from the step it shows (the wall's
    version ``shown``): dwell from the instant the tiles show it, then the next step,
    until the last has dwelt (the tour then ends, its last view kept) or the play ends
    otherwise (see the module)."""

    def playing(state: WallState) -> tuple[CensusState, Tour]:
        census = CensusState.of(state)
        if state.app != APP or not census.tour.playing or census.tour.run != run:
            raise TourEnded
        return census, census.tour

    def next_step(state: WallState) -> WallState:
        census, tour = playing(state)
        if tour.step + 1 >= len(tour.steps):
            done = tour.model_copy(
                update={"playing": False, "note": f"played all {len(tour.steps)} steps"}
            )
            return census.model_copy(update={"tour": done}).put(state)
        return at_step(state, census, tour, tour.step + 1)

    try:
        while True:
            since = await context.shown_at(wall, shown) if shown is not None else None
            state = await context.state(wall)
            _, tour = playing(state)
            # from the instant it shows (apply_at may lie ahead: then a little longer)
            passed_s = (now_ms() - since) / 1000 if since is not None else 0.0
            await sleep(tour.steps[tour.step].dwell_s - passed_s)
            change = await context.change_wall(wall, next_step)
            shown = change.version if change is not None else None
    except TourEnded:
        return
    except Exception:
        log.exception("the tour on %s ended by a fault", wall.id)
        await context.change_wall(wall, lambda state: _stopped(state, run, "a server fault"))


def _stopped(state: WallState, run: int, why: str) -> WallState:
    census = CensusState.of(state)
    if state.app != APP or census.tour.run != run:
        return state
    return census.model_copy(update={"tour": census.tour.stopped(why)}).put(state)
