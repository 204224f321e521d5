"""The brain atlas's running part: its content, views, answer keys, volumes and pins,
loaded on first use and kept, for its pages, routes and the app; what a pin's code
marks in the round on the wall (:class:`Pin`), which its pages show and phones answer.

An :class:`Atlas` reads one content folder. The app object is an :class:`Atlases`,
made before it is handed any settings, so it keeps the atlas of the content folder the
settings name (``TAGWALL_CONTENT_DIR``; a server hands it one); its pages and routes
find that atlas with :func:`brain_atlas`, so nothing below the app names the app's
class.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from fastapi import HTTPException, status

from wall_client.layout import Wall
from webapp.apps.brain_atlas.content import (
    AtlasContent,
    GroupText,
    Region,
    ResearchText,
    TagSetName,
    atlas_folder,
    load_content,
)
from webapp.apps.brain_atlas.literature import PubMed
from webapp.apps.brain_atlas.matching import AnswerKey, answer_key
from webapp.apps.brain_atlas.pins import VOLUME, AtlasVolumes, PinCache, scene_pins
from webapp.apps.brain_atlas.rules import (
    APP,
    GROUP_LABELS,
    TAG_SETS,
    group_tag,
    pin_question,
    pin_tag,
    quiz_of,
)
from webapp.apps.brain_atlas.state import BrainState
from webapp.apps.brain_atlas.views import VIEWS_NAME, ViewPreset, load_views
from webapp.core.caching import SizedCache
from webapp.core.roles import UserGroup
from webapp.core.settings import Settings
from webapp.database.models import TagRecord
from webapp.engine.wall_state import WallState, read_state
from webapp.quiz.engine import Question, Round, new_order
from webapp.tags.registry import (
    TagSpec,
    anchored_code_side_mm,
    places_anchored,
    preview,
    wall_tags,
)
from webapp.web.context import AppContext

PIN_CLEARANCE_OF_CODE = 0.75
ORDER_TRIES = 6
"""How many orders :func:`pin_order` tries at most for a view's pins."""
"""How far a pin's code stands from the point it marks, in code sides."""
PLACED_KEPT = 64
"""Placement previews kept (views x sets x rounds x walls), for the phones' hints."""
GUIDES_KEPT = 64
"""Round guides kept (sets x layouts x walls): a class's phones ask for the same few."""


@dataclass(frozen=True)
class RoundGuide:
    """A round's pins of one set as the phones' hints need them: each pin's code, the
    preset views whose placement puts it on the wall, and those on the wall now."""

    codes: dict[int, str]
    views: dict[int, list[str]]
    on_wall: frozenset[int]


@dataclass(frozen=True)
class Pin:
    """A pin as the wall shows it now: its set, number and region in the round."""

    tag: TagRecord
    tag_set: TagSetName
    number: int
    region: Region
    round: Round
    state: WallState

    @property
    def question(self) -> Question:
        return pin_question(self.region, self.tag_set)


class RoundChanged(Exception):
    """The pin's code belongs to an earlier round (or the quiz has none yet)."""

    def __init__(self, tag: TagRecord) -> None:
        super().__init__(tag.code)
        self.tag = tag


def set_of_pin(tag: TagRecord) -> TagSetName:
    """The set a pin's code belongs to."""
    return "k5" if tag.params.get("set") == "k5" else "full"


class Atlas:
    """The brain atlas's content in ``folder`` and what is computed from it, kept
    across requests. Read once: an edit takes effect when the server restarts (a round
    running keeps its pin numbers and answer keys)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self._lock = threading.Lock()
        self._content: AtlasContent | None = None
        self._views: list[ViewPreset] | None = None
        self._keys: dict[TagSetName, AnswerKey] = {}
        self._volumes: AtlasVolumes | None = None
        self._pubmed: PubMed | None = None
        self._placed: SizedCache[frozenset[str]] = SizedCache(PLACED_KEPT)
        self._guides: SizedCache[RoundGuide] = SizedCache(GUIDES_KEPT)
        self.pin_cache = PinCache()

    @property
    def content(self) -> AtlasContent:
        with self._lock:
            if self._content is None:
                self._content = load_content(self.folder)
            return self._content

    @property
    def views(self) -> list[ViewPreset]:
        with self._lock:
            if self._views is None:
                self._views = load_views(self.folder / VIEWS_NAME)
            return self._views

    @property
    def volumes(self) -> AtlasVolumes:
        with self._lock:
            if self._volumes is None:
                self._volumes = AtlasVolumes.load(self.folder)
            return self._volumes

    def pubmed(self, settings: Settings) -> PubMed:
        """The literature search, one per app so its cache serves every phone."""
        with self._lock:
            if self._pubmed is None:
                self._pubmed = PubMed(settings)
            return self._pubmed

    def has_research(self, region: Region) -> bool:
        tutor = self.content.tutors.get(region.id)
        return tutor is not None and tutor.research is not None

    def answer_key(self, tag_set: TagSetName) -> AnswerKey:
        content = self.content
        with self._lock:
            if tag_set not in self._keys:
                self._keys[tag_set] = answer_key(content, tag_set)
            return self._keys[tag_set]

    def regions(self, tag_set: TagSetName) -> list[Region]:
        """The set's regions (in the content's order, which no pin number follows)."""
        return self.content.in_set(tag_set)

    def pins(self, quiz_round: Round, tag_set: TagSetName) -> dict[int, Region]:
        """Pin number -> region of a set in a round."""
        return quiz_round.numbered(tag_set, self.regions(tag_set))

    def fresh_orders(self) -> dict[str, list[str]]:
        """A new round's pin numbering: every set in a fresh random order."""
        return {tag_set: new_order(self.regions(tag_set)) for tag_set in TAG_SETS}

    def round_on_wall(self, context: AppContext, wall_id: str, state: WallState) -> Round | None:
        """The quiz round the wall state names (None before the brain's first)."""
        number = BrainState.of(state).quiz_round
        return None if number is None else quiz_of(context).get_round(wall_id, number)

    def current_round(self, context: AppContext, wall: Wall) -> tuple[WallState, Round | None]:
        """The wall's state and the quiz round it names (synchronous: a page reads all
        it needs in one :meth:`~webapp.database.connection.Database.read`)."""
        _, state = read_state(context.db, wall.id)
        return state, self.round_on_wall(context, wall.id, state)

    async def round_now(self, context: AppContext, wall: Wall) -> tuple[WallState, Round | None]:
        """:meth:`current_round`, for a handler on the event loop."""
        return await context.db.read(self.current_round, context, wall)

    def pin(self, context: AppContext, wall: Wall, tag: TagRecord) -> Pin:
        """What the pin ``tag`` marks in the round on the wall; RoundChanged for an old
        round's (synchronous, like :meth:`current_round`)."""
        state, quiz_round = self.current_round(context, wall)
        if quiz_round is None or tag.params.get("round") != quiz_round.number:
            raise RoundChanged(tag)
        tag_set = set_of_pin(tag)
        number = int(tag.params.get("pin", 0))
        region = self.pins(quiz_round, tag_set).get(number)
        if region is None:
            raise HTTPException(status.HTTP_404_NOT_FOUND, "That pin is no longer in the atlas.")
        return Pin(tag, tag_set, number, region, quiz_round, state)

    def switch_mode(
        self, context: AppContext, wall_id: str, state: WallState, mode: str, by: str
    ) -> WallState:
        """The one rule of the atlas's modes. Tutor pages name every pin, so tutor mode
        closes the round running; quiz mode after a closed round opens a new one (new
        numbers and codes, in the same swap). ``by`` is who switched."""
        switched = state.model_copy(update={"mode": mode})
        running = self.round_on_wall(context, wall_id, state)
        if running is not None and running.open:
            if mode == "tutor":
                quiz_of(context).close_round(wall_id, running.number, by)
            return switched
        if mode == "tutor":
            return switched
        started = quiz_of(context).start_round(wall_id, by, self.fresh_orders())
        return BrainState.of(switched).later_round(started.number).put(switched)

    def guide(
        self,
        context: AppContext,
        wall: Wall,
        quiz_round: Round,
        tag_set: TagSetName,
        state: WallState,
    ) -> RoundGuide:
        """Where the round's pins of ``tag_set`` are, for the phones' hints; one per
        layout of the wall. Every change of the wall's tags (a round's pins declared, a
        tag issued, a view turned) places them anew, so a new ``state.tag_layout``."""
        key = (wall.id, quiz_round.number, tag_set, state.tag_layout, context.base_url)
        found = self._guides.get(key)
        if found is not None:
            return found
        layout = context.layout(wall.id, state.tag_layout)
        placed = {code["code"] for code in layout.placed} if layout is not None else set()
        pins = {
            int(tag.params["pin"]): tag.code
            for tag in wall_tags(context.db, wall.id)
            if tag.app == APP
            and tag.action == "pin"
            and tag.params.get("set") == tag_set
            and tag.params.get("round") == quiz_round.number
        }
        found = RoundGuide(
            codes=pins,
            views=self._pin_views(context, wall, quiz_round, tag_set),
            on_wall=frozenset(number for number, code in pins.items() if code in placed),
        )
        self._guides.put(key, found)
        return found

    def unshown(
        self, context: AppContext, wall: Wall, quiz_round: Round, tag_set: TagSetName
    ) -> list[Region]:
        """The regions of ``tag_set`` whose pin no preset view puts on ``wall`` (its
        code finds no place in any): no student can scan them this round, so the
        instructor's dashboard names them before the round runs (issue 31)."""
        views = self._pin_views(context, wall, quiz_round, tag_set)
        return [
            region for n, region in sorted(self.pins(quiz_round, tag_set).items()) if n not in views
        ]

    def _pin_views(
        self, context: AppContext, wall: Wall, quiz_round: Round, tag_set: TagSetName
    ) -> dict[int, list[str]]:
        """Per pin number, the names of the preset views in which its code stands on
        ``wall`` (placed, so scannable: a pin the picture shows may find no room for
        its code). Phones send students only where they can scan the pin.

        Each view is placed as the wall would place it (``webapp.tags.registry.preview``), and
        the outcome is kept by its inputs' digest: the views of another round place alike."""
        where: dict[int, list[str]] = {}
        for preset in self.views:
            state = BrainState(quiz_round=quiz_round.number).put(
                WallState(
                    app=APP,
                    mode="quiz",
                    view=preset.view,
                    volume=preset.layer(VOLUME),
                    tag_set=TAG_SETS[tag_set],
                )
            )
            specs = self.declare_tags(context, wall, state)
            planned = preview(
                context.db, wall, TAG_SETS[tag_set], context.base_url, context.installed, APP, specs
            )
            placed = self._placed.get(planned.digest)
            if placed is None:
                placed = frozenset(planned.placed_names())
                self._placed.put(planned.digest, placed)
            for spec in specs:
                if (
                    spec.name in placed
                    and spec.action == "pin"
                    and spec.tag_set == TAG_SETS[tag_set]
                ):
                    where.setdefault(int(spec.params["pin"]), []).append(preset.name)
        return where

    def preset(self, preset_id: str) -> ViewPreset | None:
        return next((v for v in self.views if v.id == preset_id), None)

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """While the brain is on the wall: the user-group menu on the menu screen and a
        pin on every region of each set that the current picture shows, numbered and
        named for the round on the wall (a new round: new codes)."""
        if state.app != APP or state.volume is None or state.volume.volume != VOLUME:
            return []
        quiz_round = self.round_on_wall(context, wall.id, state)
        menu = group_menu()
        clear = PIN_CLEARANCE_OF_CODE * anchored_code_side_mm(context.base_url, wall)
        pins = []
        for tag_set, tag_set_name in TAG_SETS.items() if quiz_round is not None else ():
            assert quiz_round is not None
            numbered = self.pins(quiz_round, tag_set)
            points = self.pin_points(context, wall, state, list(numbered.values()))
            shown = [(r.id, points[r.id]) for r in self.regions(tag_set) if r.id in points]
            rank = {
                region_id: i
                for i, region_id in enumerate(
                    pin_order(
                        shown,
                        lambda anchors: places_anchored(wall, context.base_url, anchors, clear),
                    )
                )
            }
            pins += [
                TagSpec(
                    name=pin_tag(tag_set, quiz_round.number, number),
                    label=f"Pin {number}",
                    app=APP,
                    action="pin",
                    params={"set": tag_set, "round": quiz_round.number, "pin": number},
                    tag_set=tag_set_name,
                    anchor=points[region.id],
                    clear_mm=clear,
                    # Placed in the order pin_order gives, the same in every round
                    # (and so are the places): a layout lists codes in code order.
                    priority=-1 - rank[region.id],
                )
                for number, region in sorted(numbered.items())
                if region.id in points
            ]
        return menu + pins

    def pin_points(
        self, context: AppContext, wall: Wall, state: WallState, regions: list[Region]
    ) -> dict[str, tuple[float, float]]:
        """Where each region's pin head stands on the wall now (scene mm), for the
        regions the picture shows. A head may be on a designated screen (the brain is
        drawn there too); its code then stands on the nearest free display, on a pin."""
        assert state.volume is not None
        store = context.volumes.get(state.volume.volume)
        on_plane = self.pin_cache.get(self.volumes, regions, state.view, state.volume)
        return scene_pins(on_plane, wall, state.view, store.meta)

    def tutor_text(
        self, region: Region, group: UserGroup
    ) -> tuple[UserGroup, GroupText | ResearchText] | None:
        """The region's text for ``group`` and whom it was written for: children get
        the children's text of every region; the other groups their own, or (on a
        K-5 pin, which has only a children's text) that one, labelled as such."""
        tutor = self.content.tutors.get(region.id)
        if tutor is None:
            return None
        if group == "k5" or "full" not in region.sets:
            return ("k5", tutor.k5) if tutor.k5 is not None else None
        chosen = getattr(tutor, group) or tutor.undergraduate
        audience: UserGroup = group if getattr(tutor, group) is not None else "undergraduate"
        return (audience, chosen) if chosen is not None else None


def group_menu() -> list[TagSpec]:
    """The user-group menu, on the menu screen whenever the brain is on the wall."""
    return [
        TagSpec(
            name=group_tag(group),
            label=label,
            app=APP,
            action="group",
            params={"group": group},
            screen="menu",
            slot=slot,
        )
        for slot, (group, label) in enumerate(GROUP_LABELS.items(), start=1)
    ]


class Atlases:
    """The atlas of each content folder the app is handed settings for: one per server
    (the app object is made before the settings are handed to it)."""

    def __init__(self) -> None:
        self._atlases_lock = threading.Lock()
        self._atlases: dict[Path, Atlas] = {}
        self._last: tuple[Settings, Atlas] | None = None

    def atlas(self, settings: Settings) -> Atlas:
        """The atlas of the content folder of ``settings``. A server asks with the same
        settings on every phone's request: the last answer is kept for them, not looked
        for again on the disk (the folder is read once anyway, :class:`Atlas`)."""
        last = self._last
        if last is not None and last[0] is settings:
            return last[1]
        folder = atlas_folder(settings)
        with self._atlases_lock:
            found = self._atlases.get(folder)
            if found is None:
                found = self._atlases[folder] = Atlas(folder)
            self._last = (settings, found)
            return found


def brain_atlas(context: AppContext) -> Atlas:
    """The installed brain atlas, reading the content folder of the context's settings."""
    app = context.app(APP)
    if not isinstance(app, Atlases):
        raise TypeError(f"the installed {APP!r} app is not the brain atlas")
    return app.atlas(context.settings)


def pin_order(
    pins: Sequence[tuple[str, tuple[float, float]]],
    places: Callable[[list[tuple[str, tuple[float, float]]]], set[str]],
) -> list[str]:
    """The order to place a view's ``pins`` (region id and head, in the content's order)
    in: the content's order, unless some then find no spot, tried with ``places`` (the
    keys that find a spot, placed in the order given).

    Pins never cross, so in a crowded view (the deep structures) the pins placed first
    can fence in a head placed late, whose code then finds no way to it. The pins left
    out go first and the rest follow, tried again up to :data:`ORDER_TRIES` times; the
    order leaving fewest out wins (the first such). It depends only on the view, the
    wall and the set: the same in every round."""
    order = list(pins)
    best: tuple[int, list[tuple[str, tuple[float, float]]]] | None = None
    for _ in range(ORDER_TRIES):
        placed = places(order)
        left_out = [pin for pin in order if pin[0] not in placed]
        if best is None or len(left_out) < best[0]:
            best = (len(left_out), order)
        if not left_out:
            break
        order = left_out + [pin for pin in order if pin[0] in placed]
    return [key for key, _ in (best[1] if best is not None else order)]
