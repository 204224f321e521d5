"""The census map's running part: the data sets it shows, their geometry on the plane
and their colourings, each computed once and kept, for its pages, routes and tiles.

The app object is a :class:`CensusMaps`; its pages and routes find it with
:func:`census_maps`, so nothing below the app names the app's class.
"""

from __future__ import annotations

import asyncio
import threading
from collections import OrderedDict

from wall_client.layout import Wall
from webapp.apps.census_map.charts import ChartStats
from webapp.apps.census_map.dataset import DataSet, Tract
from webapp.apps.census_map.ground import GroundRelay, GroundSettings, ground_settings
from webapp.apps.census_map.mapview import MapGeometry
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.store import DataSets
from webapp.apps.census_map.theme import Shading, kept_theme, shade
from webapp.choropleth.classes import Theme
from webapp.core.caching import SizedCache
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState
from webapp.web.context import AppContext

KEPT_GEOMETRIES = 4
KEPT_SHADINGS = 64  # themes tried in a session, per data set: each a few kB
RENDER_CACHE_BYTES = 64 * 1024 * 1024


class CensusMaps:
    """The census map's data and what is computed from it, kept across requests."""

    def __init__(self, ground: GroundSettings | None = None) -> None:
        """``ground``: the globe's imagery and terrain servers (default: the
        environment's ``TAGWALL_CENSUS_*``; a bad one stops the app loading)."""
        self.datasets = DataSets()
        self.ground = GroundRelay(ground or ground_settings())
        self.renders = SizedCache[bytes](RENDER_CACHE_BYTES, len)  # tile views, KML
        self.chart_stats = ChartStats()
        self.shadings = SizedCache[Shading](KEPT_SHADINGS)
        self._geometries: OrderedDict[int, MapGeometry] = OrderedDict()
        self._lock = threading.Lock()
        self.tours: dict[str, asyncio.Task[None]] = {}  # by wall: this process's tour drivers

    # --- data ----------------------------------------------------------------------

    def dataset(self, context: AppContext, dataset_id: int | None) -> DataSet | None:
        return self.datasets.get(context.db, dataset_id) if dataset_id else None

    def geometry(self, dataset: DataSet) -> MapGeometry:
        """The data set on the plane: computed once per data set, kept for a few."""
        with self._lock:
            if dataset.id in self._geometries:
                self._geometries.move_to_end(dataset.id)
                return self._geometries[dataset.id]
        geometry = MapGeometry.of(dataset)
        with self._lock:
            self._geometries[dataset.id] = geometry
            while len(self._geometries) > KEPT_GEOMETRIES:
                self._geometries.popitem(last=False)
        return geometry

    def shading(self, dataset: DataSet, theme: Theme | None) -> Shading | None:
        """The tracts coloured by ``theme`` (None: the plain map), cut once per data set
        and theme: tiles, KML and tract pages all read the same classes."""
        theme = kept_theme(dataset, theme)
        if theme is None:
            return None
        key = (dataset.id, theme)
        found = self.shadings.get(key)
        if found is None:
            found = shade(dataset, theme)
            self.shadings.put(key, found)
        return found

    def shown(self, context: AppContext, state: WallState) -> DataSet | None:
        """The data set the wall's state names (None: the census map is not set up)."""
        return self.dataset(context, CensusState.of(state).dataset)

    async def tract_on_wall(
        self, context: AppContext, wall: Wall, geoid: str
    ) -> tuple[WallState, DataSet | None, Tract | None]:
        state = await context.state(wall)
        dataset = await run_blocking(self.shown, context, state)
        return state, dataset, dataset.tract(geoid) if dataset else None


def census_maps(context: AppContext) -> CensusMaps:
    """The installed census map's maps."""
    maps = context.app(APP)
    if not isinstance(maps, CensusMaps):
        raise TypeError(f"the installed {APP!r} app is not the census map")
    return maps
