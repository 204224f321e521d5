"""What phones do to the census map on the wall: flip a tract group, open a balloon.

Each is one state change through the door (``webapp.changes.door``); a balloon is placed
while the door holds the wall, so two opened at once never land on each other.
"""

from __future__ import annotations

import math

from tag_service.placement import place_box
from wall_client.layout import Rect, Wall
from webapp.apps.census_map.dataset import DataSet, Group, Tract
from webapp.apps.census_map.globe import map_projection
from webapp.apps.census_map.maps import CensusMaps
from webapp.apps.census_map.mapview import (
    MapGeometry,
    grown,
    label_mm,
    looking_at,
    pointer_targets,
)
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.state import CensusState, Surface
from webapp.apps.census_map.theme import kept_theme
from webapp.choropleth.classes import Theme
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import Balloon, View, WallState, now_ms
from webapp.tags.schemas import PlacedCode
from webapp.web.context import AppContext, Update

MAX_BALLOONS = 8
LINE_HEIGHT = 1.35  # of the font size
CHAR_WIDTH = 0.56  # of the font size, a generous average for sans-serif text
BALLOON_FONT_OF_LABEL = 1.2
CLEAR_PX = 6  # balloons.js: a dot of radius 4 px, lines 2 px wide, anti-aliased edges


def group_shown(state: WallState, group_id: str) -> bool:
    """Groups are shown unless their layer was switched off."""
    return state.layers.get(group_id, True)


def hidden_group(state: WallState, dataset: DataSet, tract: Tract) -> Group | None:
    """The tract's group when the wall hides it (its tract is not drawn), else None."""
    group_id = dataset.group_of.get(tract.geoid)
    if group_id is None or group_shown(state, group_id):
        return None
    return next(g for g in dataset.groups if g.id == group_id)


class NoRoom(Exception):
    """No spot on the wall for the balloon clear of every code, caption and balloon."""


class GroupHidden(Exception):
    """A balloon for a tract the wall does not show would point at empty map."""

    def __init__(self, group: Group) -> None:
        super().__init__(f"the group {group.name} is hidden on the wall")
        self.group = group


class OffTheWall(Exception):
    """The wall shows no part of the tract (its globe looks elsewhere: the tract lies
    beyond the wall's edge or over the horizon): a balloon would point at nothing."""


class MapChanged(Exception):
    """The wall stopped showing the data set a colouring was chosen for."""


class NoSuchValue(Exception):
    """The data set has no value by the name the colouring gives."""


def shown_census(state: WallState) -> CensusState:
    """The census slot of a wall that shows the census map; :class:`MapChanged` when it
    shows another app (a change meant for the map must not land on it)."""
    if state.app != APP:
        raise MapChanged
    return CensusState.of(state)


async def colour_wall(
    context: AppContext, wall: Wall, dataset: DataSet, theme: Theme | None
) -> None:
    """Colour the wall's tracts by ``theme`` (None: one plain colour), on every tile in
    the same frame (a heavy change: tiles load the classes before the swap). Raises
    :class:`NoSuchValue` when ``dataset`` lacks the theme's value and
    :class:`MapChanged` when the wall no longer shows ``dataset``."""
    if theme is not None and kept_theme(dataset, theme) is None:
        raise NoSuchValue(theme.attribute)

    async def colour(state: WallState) -> Update:
        if shown_census(state).dataset != dataset.id:
            raise MapChanged
        return lambda current: (
            CensusState.of(current).model_copy(update={"theme": theme}).put(current)
        )

    await context.plan_change(wall, colour)


def with_census(state: WallState, census: CensusState) -> WallState:
    """``state`` with the census slot ``census``; where that moves the tracts on the
    wall (another surface, the globe turned or tilted) the balloons close in the same
    change: they point where their tracts were."""
    changed = census.put(state)
    moved = census.moves_tracts(CensusState.of(state))
    return changed.model_copy(update={"balloons": []}) if moved else changed


async def choose_surface(context: AppContext, wall: Wall, surface: Surface) -> None:
    """Draw the map flat or on a globe, on every tile in the same frame (a heavy change:
    tiles load the globe first). Raises :class:`MapChanged` when the census map is not
    on the wall."""

    def switch(state: WallState) -> WallState:
        return with_census(state, shown_census(state).model_copy(update={"surface": surface}))

    await context.change_wall(wall, switch)


async def aim_camera(context: AppContext, wall: Wall, heading: float, tilt: float) -> None:
    """Turn and tilt the globe's camera, on every tile in the same frame (a heavy
    change: tiles render the new picture first); a tour playing stops (the instructor
    took the camera). Raises :class:`MapChanged` when the census map is not on the
    wall."""

    def aim(state: WallState) -> WallState:
        census = shown_census(state)
        tour = census.tour.stopped("the instructor turned the camera")
        return with_census(
            state, census.model_copy(update={"heading": heading, "tilt": tilt, "tour": tour})
        )

    await context.change_wall(wall, aim)


async def fly_to(
    context: AppContext,
    wall: Wall,
    geometry: MapGeometry,
    middle: tuple[float, float],
    place: tuple[float, float],
    zoom: float | None,
) -> View:
    """Look at the plane point ``place`` of ``geometry``'s map from ``middle``, the
    middle of the wall (:func:`~webapp.apps.census_map.globe.wall_middle`), at ``zoom``
    or the zoom the wall has: the wall's one view, so the flat
    map and the globe both go there, on every tile in the same frame. A tour playing
    stops. Raises :class:`MapChanged` when the census map is not on the wall."""
    flown: View | None = None

    def fly(state: WallState) -> WallState:
        nonlocal flown
        census = shown_census(state)
        view = state.view if zoom is None else state.view.model_copy(update={"zoom": zoom})
        flown = looking_at(geometry, wall, view, middle, *place)
        tour = census.tour.stopped("the instructor flew to a place")
        return census.model_copy(update={"tour": tour}).put(
            state.model_copy(update={"view": flown})
        )

    await context.change_wall(wall, fly)
    assert flown is not None
    return flown


async def toggle_group(context: AppContext, wall: Wall, group_id: str) -> bool:
    """Flip a group's visibility on every tile; returns whether it is shown now."""
    shown_now = False

    def flip(state: WallState) -> WallState:
        nonlocal shown_now
        shown_now = not group_shown(state, group_id)
        return state.model_copy(update={"layers": {**state.layers, group_id: shown_now}})

    await context.change_wall(wall, flip)
    return shown_now


def balloon_size(title: str, lines: list[str], font_mm: float) -> tuple[float, float]:
    """A box holding ``title`` over ``lines`` at ``font_mm``, padding included; tiles
    fit the text to the box they are given."""
    longest = max(len(text) for text in [title, *lines])
    return (font_mm * (CHAR_WIDTH * longest + 1), font_mm * (LINE_HEIGHT * (1 + len(lines)) + 1))


async def open_balloon(
    app: CensusMaps, context: AppContext, wall: Wall, dataset: DataSet, tract: Tract
) -> Balloon:
    """Open the tract's balloon beside it, clear of codes and other open balloons; it
    closes by itself after ``TAGWALL_BALLOON_SECONDS`` (the oldest goes when too many
    are open). The tract stands where the wall shows it: on the flat map, or where the
    globe's camera, turned and tilted as it is, shows it (:func:`globe.map_projection`).
    Raises :class:`GroupHidden` when the wall hides the tract's group,
    :class:`OffTheWall` when the globe shows no part of it and :class:`NoRoom` when the
    wall has no room for it.

    Nothing of a balloon touches a code's symbol, quiet zone or caption: its dot marks
    the tract where no code stands (at the edge of the tract's own code, which stands
    on the tract's label point), its box stands clear of codes beside the tract,
    preferably where the pointer from it to the dot crosses no code either (where codes
    crowd the map, the pointer passes under them: tiles draw pointers before codes)."""
    opened: Balloon | None = None

    async def place(state: WallState) -> Update:
        nonlocal opened
        hidden = hidden_group(state, dataset, tract)
        if hidden is not None:
            raise GroupHidden(hidden)
        layout = await run_blocking(context.layout, wall.id, state.tag_layout)
        geometry = await run_blocking(app.geometry, dataset)
        camera = CensusState.of(state).camera
        mapping = await run_blocking(map_projection, geometry, wall, state.view, *camera)
        now = now_ms()
        open_ = [b for b in state.balloons if b.open_at(now) and b.id != f"tract-{tract.geoid}"]
        others = open_[-(MAX_BALLOONS - 1) :]  # the oldest goes when too many are open
        margin = CLEAR_PX * max(d.mm_per_px for d in wall.displays)
        codes = [
            grown(Rect(*PlacedCode.model_validate(placed).footprint), margin)
            for placed in (layout.placed if layout else [])
        ]
        obstacles = codes + [grown(Rect(*b.rect), margin) for b in others if b.rect]
        targets = await run_blocking(
            pointer_targets,
            geometry,
            wall,
            state.view,
            tract.geoid,
            obstacles,
            margin,
            mapping=mapping,
        )
        if not targets:
            raise OffTheWall
        title = dataset.tract_title(tract)
        lines = [f"{label}: {value}" for label, value in dataset.headline(tract)]
        font = label_mm(wall) * BALLOON_FONT_OF_LABEL
        keep_clear = 2 * label_mm(wall)  # the dot and the tract around it stay visible
        size = balloon_size(title, lines, font)
        anchor, box = await run_blocking(
            _place_balloon, wall, size, targets, obstacles, keep_clear, codes
        )
        opened = Balloon(
            id=f"tract-{tract.geoid}",
            anchor=anchor,
            rect=box.xywh,
            title=title,
            lines=lines,
            closes_at=now + context.settings.balloon_seconds * 1000,
        )
        kept = [*others, opened]
        return lambda current: current.model_copy(update={"balloons": kept})

    await context.plan_change(wall, place)
    assert opened is not None
    return opened


def _place_balloon(
    wall: Wall,
    size: tuple[float, float],
    targets: list[tuple[float, float]],
    obstacles: list[Rect],
    keep_clear: float,
    codes: list[Rect],
) -> tuple[tuple[float, float], Rect]:
    """The first target (best first) with a box beside it whose pointer crosses no code
    and no public screen (a publication covers what lies under it); where codes crowd
    the map so that none has one, the first target with the nearest box (its pointer
    passes under codes: tiles draw pointers before codes).

    Beside means a pointer no longer than the box's longer side: a box further off,
    on another display or across the wall, is not seen as the tract's balloon."""
    reach = max(size)
    sight = codes + [wall.viewport(d.id).scene_rect for d in wall.screen("public")]
    for target in targets:
        box = place_box(wall, size, target, obstacles, keep_clear, sight=sight)
        if box is not None and _pointer_length(box, target) <= reach:
            return target, box
    box = place_box(wall, size, targets[0], obstacles, keep_clear)
    if box is None:
        raise NoRoom
    return targets[0], box


def _pointer_length(box: Rect, anchor: tuple[float, float]) -> float:
    """How long the line from the box's nearest point to ``anchor`` is (balloons.js)."""
    x, y = anchor
    return math.dist((min(max(x, box.x), box.right), min(max(y, box.y), box.bottom)), anchor)


async def switch_dataset(app: CensusMaps, context: AppContext, dataset_id: int) -> None:
    """Show ``dataset_id`` on every wall the census map is on (codes placed again; the
    colouring kept where the data set has its value)."""
    dataset = await run_blocking(app.dataset, context, dataset_id)
    for wall in context.walls.values():

        def show(state: WallState) -> WallState:
            if state.app != APP:
                return state
            census = CensusState.of(state)
            theme = kept_theme(dataset, census.theme)
            tour = census.tour.stopped("another data set went on the wall")
            return census.model_copy(
                update={"dataset": dataset_id, "theme": theme, "tour": tour}
            ).put(state)

        await context.change_wall(wall, show)
