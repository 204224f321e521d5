"""The brain atlas: the MNI brain across the wall with a red pin on each region, a quiz
whose answers only instructors see early, and a tutor per user group.

The wall state says what is shown: ``volume`` and ``view`` (one of the presets in
``content/brain_atlas/views.yaml``, or wherever the instructor turned it), ``mode``
(quiz or tutor) and ``tag_set`` (the K-5 pins or the full set). Pins are computed
from the label volume for exactly that picture (``pins``), so a pin always marks a
point of its region the wall shows. Pins carry numbers, never names: a pin's code,
label and parameters tell nothing about the answer.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Literal

from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps import Scan
from webapp.apps.brain_atlas.content import (
    ATLAS_DIR,
    AtlasContent,
    GroupText,
    Region,
    ResearchText,
    TagSetName,
    load_content,
)
from webapp.apps.brain_atlas.literature import PubMed
from webapp.apps.brain_atlas.matching import AnswerKey
from webapp.apps.brain_atlas.pins import TEMPLATE_FILE, VOLUME, AtlasVolumes, PinCache, scene_pins
from webapp.apps.brain_atlas.views import ViewPreset, load_views, showing
from webapp.people import Person
from webapp.publishing import Block, Publication
from webapp.settings import Settings, UserGroup
from webapp.tags import TagSpec, anchored_code_side_mm
from webapp.volume.build import build_store, open_source
from webapp.wall_state import WallState

if TYPE_CHECKING:
    from webapp.services import Services

APP = "brain"
Mode = Literal["quiz", "tutor"]
MODES: tuple[Mode, ...] = ("quiz", "tutor")
TAG_SETS: dict[TagSetName, str] = {"k5": "brain-k5", "full": "brain-full"}
GROUP_LABELS: dict[UserGroup, str] = {
    "k5": "K-5",
    "undergraduate": "Undergraduate",
    "medical": "Medical",
    "research": "Research",
}
PIN_CLEARANCE_OF_CODE = 0.75
"""How far a pin's code stands from the point it marks, in code sides."""


def set_of_group(group: UserGroup) -> TagSetName:
    """Children get the K-5 pins; every other group the full set."""
    return "k5" if group == "k5" else "full"


def set_on_wall(state: WallState) -> TagSetName:
    """Which pins the wall shows now (the full set unless K-5 was chosen)."""
    return "k5" if state.tag_set == TAG_SETS["k5"] else "full"


def mode_of(state: WallState) -> Mode:
    return "tutor" if state.mode == "tutor" else "quiz"


def reveals_answers(person: Person) -> bool:
    """The one rule for early answers: instructors (and admins) see them at once;
    students only on their own results page, after finishing."""
    return person.is_staff


def pin_tag(tag_set: TagSetName, number: int) -> str:
    return f"brain:{tag_set}:pin:{number}"


def group_tag(group: UserGroup) -> str:
    return f"brain:group:{group}"


class BrainApp:
    name: str = APP
    default_tag_set: str | None = TAG_SETS["full"]

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._content: AtlasContent | None = None
        self._views: list[ViewPreset] | None = None
        self._keys: dict[TagSetName, AnswerKey] = {}
        self._volumes: AtlasVolumes | None = None
        self._pubmed: PubMed | None = None
        self._views_showing: dict[str, list[str]] | None = None
        self.pins = PinCache()

    # --- content, loaded on first use ------------------------------------------------

    @property
    def content(self) -> AtlasContent:
        with self._lock:
            if self._content is None:
                self._content = load_content()
            return self._content

    @property
    def views(self) -> list[ViewPreset]:
        with self._lock:
            if self._views is None:
                self._views = load_views()
            return self._views

    @property
    def volumes(self) -> AtlasVolumes:
        with self._lock:
            if self._volumes is None:
                self._volumes = AtlasVolumes.load()
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
                self._keys[tag_set] = content.answer_key(tag_set)
            return self._keys[tag_set]

    def regions(self, tag_set: TagSetName) -> list[Region]:
        """The set's regions in pin order (pin n is the n-th)."""
        return self.content.in_set(tag_set)

    def region_of_pin(self, tag_set: TagSetName, number: int) -> Region | None:
        regions = self.regions(tag_set)
        return regions[number - 1] if 1 <= number <= len(regions) else None

    def views_showing(self) -> dict[str, list[str]]:
        """Per region id, the names of the preset views that show its pin, the one
        showing most of it first (phones say where to find a pin not on the wall
        now). Presets and content do not change while the server runs: computed once."""
        with self._lock:
            if self._views_showing is not None:
                return self._views_showing
        presets = self.views
        shown = showing(presets, self.content.regions, self.volumes, self.pins)
        names = {preset.id: preset.name for preset in presets}
        found = {region: [names[p] for p in ids] for region, ids in shown.items()}
        with self._lock:
            self._views_showing = found
        return found

    def preset(self, preset_id: str) -> ViewPreset | None:
        return next((v for v in self.views if v.id == preset_id), None)

    # --- the WallApp interface -------------------------------------------------------

    def settle(self, services: Services, state: WallState) -> WallState:
        """On the wall the brain shows the MNI template (its store built on first use)
        in the first preset view, in quiz mode, unless it is already up."""
        if VOLUME not in services.volumes:
            build_store(
                open_source(ATLAS_DIR / TEMPLATE_FILE),
                services.settings.resolved_volume_dir / VOLUME,
                name=VOLUME,
            )
        update: dict[str, object] = {}
        if state.mode not in MODES:
            update["mode"] = "quiz"
        if state.volume is None or state.volume.volume != VOLUME:
            first = self.views[0]
            update["view"] = first.view
            update["volume"] = first.layer(VOLUME)
        return state.model_copy(update=update) if update else state

    def declare_tags(self, services: Services, wall: Wall, state: WallState) -> list[TagSpec]:
        """While the brain is on the wall: the user-group menu on the menu screen and a
        pin on every region of each set that the current picture shows."""
        if state.app != APP or state.volume is None or state.volume.volume != VOLUME:
            return []
        menu = [
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
        clear = PIN_CLEARANCE_OF_CODE * anchored_code_side_mm(services.base_url, wall)
        pins = []
        for tag_set, tag_set_name in TAG_SETS.items():
            regions = self.regions(tag_set)
            points = self.pin_points(services, wall, state, regions)
            pins += [
                TagSpec(
                    name=pin_tag(tag_set, number),
                    label=f"Pin {number}",
                    app=APP,
                    action="pin",
                    params={"set": tag_set, "pin": number},
                    tag_set=tag_set_name,
                    anchor=points[region.id],
                    clear_mm=clear,
                )
                for number, region in enumerate(regions, start=1)
                if region.id in points
            ]
        return menu + pins

    def pin_points(
        self, services: Services, wall: Wall, state: WallState, regions: list[Region]
    ) -> dict[str, tuple[float, float]]:
        """Where each region's pin head stands on the wall now (scene mm), for the
        regions the picture shows. A head may be on a designated screen (the brain is
        drawn there too); its code then stands on the nearest free display, on a pin."""
        assert state.volume is not None
        store = services.volumes.get(state.volume.volume)
        on_plane = self.pins.get(self.volumes, regions, state.view, state.volume)
        return scene_pins(on_plane, wall, state.view, store.meta)

    async def on_scan(self, scan: Scan) -> Response:
        from webapp.apps.brain_atlas import pages

        if scan.tag.action == "group":
            return await pages.choose_group(self, scan)
        person = await scan.person()
        return await pages.pin_page(self, scan.request, scan.services, scan.wall, scan.tag, person)

    async def publication(self, scan: Scan) -> Publication | None:
        """In tutor mode, the region's fuller page (the phone shows its summary); in
        quiz mode nothing, so the public screen never names a pin."""
        from webapp.apps.brain_atlas import pages

        if scan.tag.action != "pin":
            return None
        region = await pages.tutor_subject(self, scan.services, scan.wall, scan.tag)
        if region is None:
            return None
        person = await scan.person()
        text = self.tutor_text(region, person.user_group)
        if text is None:
            return None
        references = [self.content.references[r] for r in text.references]
        blocks = [Block(kind="markdown", text=text.text)]
        if references:
            blocks.append(
                Block(
                    kind="facts", rows=[(str(n), r.citation) for n, r in enumerate(references, 1)]
                )
            )
        return Publication(title=region.name, blocks=blocks)

    def tutor_text(self, region: Region, group: UserGroup) -> GroupText | ResearchText | None:
        """The region's text for ``group``: K-5 regions speak to children, the others
        to the visitor's group (children who scan a full-set pin get the
        undergraduate text, the plainest there is)."""
        tutor = self.content.tutors.get(region.id)
        if tutor is None:
            return None
        if "k5" in region.sets and tutor.k5 is not None:
            return tutor.k5
        chosen = tutor.undergraduate if group == "k5" else getattr(tutor, group)
        return chosen if chosen is not None else tutor.undergraduate

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "panels/brain.html"

    def router(self) -> APIRouter | None:
        from webapp.apps.brain_atlas.routes import router

        return router
