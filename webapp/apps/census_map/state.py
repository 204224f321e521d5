"""The census map's slot of the wall state: the data set shown and its colouring, how
the globe's camera is turned and tilted, and the tour of views the wall may play."""

from __future__ import annotations

from typing import Annotated, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field

from webapp.apps.census_map.rules import APP
from webapp.choropleth.classes import Theme
from webapp.database.connection import RowId
from webapp.engine.wall_state import AppState, View

Surface = Literal["flat", "globe"]
"""Where the tiles draw the map: on the flat wall plane, or on a globe (CesiumJS)."""

MAX_TILT = 60.0
"""How far the globe's camera tilts from straight down (degrees): at 60 the top of the
demo wall looks about 80 degrees from straight down, short of the horizon; a wall that
sees more than 30 degrees above its middle shows some dark sky at the top."""

Heading = Annotated[float, Field(ge=0, lt=360)]
"""Which way the top of the wall faces on the globe: degrees clockwise from north."""
Tilt = Annotated[float, Field(ge=0, le=MAX_TILT)]
"""How far the globe's camera looks from straight down towards the heading (degrees)."""

MIN_DWELL_S = 2.0
MAX_DWELL_S = 3600.0
MAX_TOUR_STEPS = 50


class TourStep(BaseModel):
    """One view of a tour: where the map looks (the wall's view: centre and zoom, both
    surfaces), the globe's heading and tilt, and how long the wall stays there."""

    model_config = ConfigDict(extra="forbid")

    center: tuple[float, float]
    zoom: float = Field(gt=0, le=1_000)
    heading: Heading = 0.0
    tilt: Tilt = 0.0
    dwell_s: float = Field(default=20.0, ge=MIN_DWELL_S, le=MAX_DWELL_S)

    def view(self, current: View) -> View:
        """``current`` looking where this step does."""
        return current.model_copy(update={"center": self.center, "zoom": self.zoom})


class Tour(BaseModel):
    """The wall's tour: its steps, and whether it plays. ``run`` counts the plays, so
    a driver whose play was stopped (or replaced by a new one) knows to end; ``note``
    says why the last play ended."""

    model_config = ConfigDict(extra="forbid")

    steps: list[TourStep] = Field(default_factory=list, max_length=MAX_TOUR_STEPS)
    playing: bool = False
    step: int = Field(default=0, ge=0)  # the step on the wall (from 0)
    run: int = Field(default=0, ge=0)
    note: str = Field(default="", max_length=200)

    def stopped(self, why: str) -> Tour:
        """This tour, no longer playing, saying why (at which step it was)."""
        if not self.playing:
            return self
        where = f"at step {self.step + 1} of {len(self.steps)}"
        return self.model_copy(update={"playing": False, "note": f"stopped {where}: {why}"})


class CensusState(AppState):
    app: ClassVar[str] = APP
    # tiles fetch the map (the globe's camera: its picture)
    heavy: ClassVar[frozenset[str]] = frozenset({"dataset", "theme", "surface", "heading", "tilt"})
    # codes stand on the data set's tracts where the surface and the globe's camera show them
    placing: ClassVar[frozenset[str]] = frozenset({"dataset", "surface", "heading", "tilt"})

    dataset: RowId | None = None  # the data set shown (None: not set up yet)
    theme: Theme | None = None  # what the tracts are coloured by (None: plain)
    surface: Surface = "flat"  # the map drawn flat, or on a globe (tiles without WebGL: flat)
    heading: Heading = 0.0  # the globe's camera turned (the flat map stays north up)
    tilt: Tilt = 0.0  # the globe's camera tilted (the flat map stays straight down)
    tour: Tour = Field(default_factory=Tour)

    @property
    def camera(self) -> tuple[Surface, float, float]:
        """Where the tiles show the map: the surface, and the globe's heading and tilt."""
        return (self.surface, self.heading, self.tilt)

    def moves_tracts(self, before: CensusState) -> bool:
        """Whether the tracts stand elsewhere on the wall than ``before``: another
        surface, or on the globe another heading or tilt (an open balloon would point
        where its tract was)."""
        if self.surface != before.surface:
            return True
        turned = (self.heading, self.tilt) != (before.heading, before.tilt)
        return self.surface == "globe" and turned
