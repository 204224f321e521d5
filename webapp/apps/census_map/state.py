"""The census map's slot of the wall state: the data set shown and its colouring."""

from __future__ import annotations

from typing import ClassVar, Literal

from webapp.apps.census_map.rules import APP
from webapp.choropleth.classes import Theme
from webapp.database.connection import RowId
from webapp.engine.wall_state import AppState

Surface = Literal["flat", "globe"]
"""Where the tiles draw the map: on the flat wall plane, or on a globe (CesiumJS)."""


class CensusState(AppState):
    app: ClassVar[str] = APP
    heavy: ClassVar[frozenset[str]] = frozenset(
        {"dataset", "theme", "surface"}
    )  # tiles fetch the map
    placing: ClassVar[frozenset[str]] = frozenset({"dataset"})  # codes stand on its tracts

    dataset: RowId | None = None  # the data set shown (None: not set up yet)
    theme: Theme | None = None  # what the tracts are coloured by (None: plain)
    surface: Surface = "flat"  # the map drawn flat, or on a globe (tiles without WebGL: flat)
