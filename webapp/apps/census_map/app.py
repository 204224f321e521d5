"""The census map as a wall app: the data set it shows, the codes on its tracts, its
pages and publications."""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click
from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps.census_map import commands, pages
from webapp.apps.census_map.charts import ChartStats, charts_for
from webapp.apps.census_map.dataset import DataSet, Tract
from webapp.apps.census_map.importer import seed
from webapp.apps.census_map.mapview import MapGeometry, tract_codes
from webapp.apps.census_map.routes import datasets, earth, phones, tiles
from webapp.apps.census_map.rules import APP, CENSUS_SET, INDEX_TAG
from webapp.apps.census_map.store import DataSets, current_id
from webapp.apps.census_map.theme import Shading, kept_theme, shade
from webapp.apps.contract import Scan, static_url
from webapp.choropleth.classes import Theme
from webapp.core.caching import SizedCache
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import WallState, read_state
from webapp.publishing.publication import Block, Publication
from webapp.tags.registry import (
    TagSpec,
    anchored_code_side_mm,
    anchored_footprint_mm,
    places_anchored,
)

if TYPE_CHECKING:
    from webapp.server.services import Services

FOLDER = Path(__file__).parent
KEPT_GEOMETRIES = 4
KEPT_SHADINGS = 64  # themes tried in a session, per data set: each a few kB
RENDER_CACHE_BYTES = 64 * 1024 * 1024


def group_tag(group_id: str) -> str:
    return f"census:group:{group_id}"


def tract_tag(geoid: str) -> str:
    return f"census:tract:{geoid}"


CLUSTER_PREFIX = "census:cluster:"
FIRST_PRIORITY = 1000  # the census map's anchored codes count down from here


def cluster_tag(geoids: tuple[str, ...]) -> str:
    """A cluster's tag is named by its tracts: the same neighbourhood gets the same code
    whenever a view clusters it so (printed and photographed codes keep working)."""
    digest = hashlib.sha256("|".join(sorted(geoids)).encode()).hexdigest()[:16]
    return f"{CLUSTER_PREFIX}{digest}"


class CensusApp:
    name: str = APP
    default_tag_set: str | None = CENSUS_SET
    layers: tuple[str, ...] = (f"{static_url(APP)}/census.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def __init__(self) -> None:
        self.datasets = DataSets()
        self.renders = SizedCache[bytes](RENDER_CACHE_BYTES, len)  # tile views, KML
        self.chart_stats = ChartStats()
        self.shadings = SizedCache[Shading](KEPT_SHADINGS)
        self._geometries: OrderedDict[int, MapGeometry] = OrderedDict()
        self._lock = threading.Lock()

    # --- data ----------------------------------------------------------------------

    def dataset(self, services: Services, dataset_id: int | None) -> DataSet | None:
        return self.datasets.get(services.db, dataset_id) if dataset_id else None

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

    def shown(self, services: Services, state: WallState) -> DataSet | None:
        """The data set the wall's state names (None: the census map is not set up)."""
        return self.dataset(services, state.dataset)

    # --- the WallApp interface -----------------------------------------------------

    def leave(self, state: WallState) -> WallState:
        return state

    def settle(self, services: Services, wall: Wall, state: WallState) -> WallState:
        """On the wall, the map shows the current data set (the shipped one until an
        import): seeded on first use, so walls that never show the map pay nothing."""
        dataset_id = current_id(services.db) or seed(services.db)
        theme = kept_theme(self.dataset(services, dataset_id), state.theme)
        return state.model_copy(update={"dataset": dataset_id, "theme": theme})

    def declare_tags(self, services: Services, wall: Wall, state: WallState) -> list[TagSpec]:
        """While the map is on the wall: the group toggles on the menu screen, the tract
        index on the registration screen, a code on every tract that has room for one
        at this view, and a cluster code over each neighbourhood of tracts too small
        for theirs, so every tract on the map is reached by pointing at the wall."""
        dataset = self.shown(services, state) if state.app == APP else None
        if dataset is None:
            return []
        menu = [
            # beside the registration codes: the menu screen is full with ten toggles
            self._spec(INDEX_TAG, "Tract index", "index", {}, screen="registration", slot=2),
            *(
                self._spec(
                    group_tag(group.id),
                    group.name,
                    "toggle",
                    {"group": group.id},
                    screen="menu",
                    slot=slot,
                )
                for slot, group in enumerate(dataset.groups, start=1)
            ),
        ]
        codes = tract_codes(
            self.geometry(dataset),
            wall,
            state.view,
            anchored_code_side_mm(services.base_url, wall),
            anchored_footprint_mm(services.base_url, wall),
        )
        codes = codes.keeping(places_anchored(wall, services.base_url, codes.anchors()))
        # falling priorities keep the wall's placement in the order just tried
        order = {key: FIRST_PRIORITY - n for n, (key, _) in enumerate(codes.anchors())}
        tracts = [
            self._spec(
                tract_tag(t.geoid),
                t.label,
                "tract",
                {"geoid": t.geoid},
                anchor=codes.own[t.geoid],
                priority=order[f"tract:{t.geoid}"],
            )
            for t in dataset.tracts
            if t.geoid in codes.own
        ]
        clusters = [
            self._spec(
                cluster_tag(cluster.geoids),
                f"{len(cluster.geoids)} tracts",
                "cluster",
                {"geoids": list(cluster.geoids)},
                anchor=cluster.anchor,
                priority=order[f"cluster:{n}"],
            )
            for n, cluster in enumerate(codes.clusters)
        ]
        return menu + tracts + clusters

    def _spec(
        self,
        name: str,
        label: str,
        action: str,
        params: dict[str, Any],
        *,
        screen: str | None = None,
        slot: int = 0,
        anchor: tuple[float, float] | None = None,
        priority: int = 0,
    ) -> TagSpec:
        return TagSpec.model_validate(
            {
                "name": name,
                "label": label,
                "app": APP,
                "action": action,
                "params": params,
                "tag_set": CENSUS_SET,
                "screen": screen,
                "slot": slot,
                "anchor": anchor,
                "priority": priority,
            }
        )

    async def on_scan(self, scan: Scan) -> Response:
        action = scan.tag.action
        if action == "toggle":
            return await pages.toggle(self, scan)
        if action == "tract":
            return await pages.tract_choice(
                self, scan.request, scan.services, scan.wall, scan.tag.params.get("geoid", "")
            )
        if action == "cluster":
            return await pages.cluster(self, scan)
        return await pages.index(self, scan.request, scan.services, scan.wall)

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        return None  # the core's page says it

    async def publication(self, scan: Scan) -> Publication | None:
        """The tract page as its publisher sees it: the values and charts of their class."""
        geoid = scan.subject or scan.tag.params.get("geoid")
        if not geoid:
            return None
        _, dataset, tract = await self.tract_on_wall(scan.services, scan.wall, geoid)
        if dataset is None or tract is None:
            return None
        person = await scan.person()
        charts = charts_for(dataset, tract, person.info_class, self.chart_stats)
        return Publication(
            title=dataset.tract_title(tract),
            blocks=[
                Block(kind="text", text=dataset.title),
                Block(
                    kind="facts",
                    rows=[(f.label, f.text()) for f in dataset.facts(tract, person.info_class)],
                ),
                *(Block(kind="chart", svg=svg) for svg in charts),
            ],
        )

    async def tract_on_wall(
        self, services: Services, wall: Wall, geoid: str
    ) -> tuple[WallState, DataSet | None, Tract | None]:
        _, state = await run_blocking(read_state, services.db, wall.id)
        dataset = await run_blocking(self.shown, services, state)
        return state, dataset, dataset.tract(geoid) if dataset else None

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "census/panel.html"

    def router(self) -> APIRouter | None:
        router = APIRouter()
        for room in (phones, tiles, earth, datasets):  # phones' paths first: most asked for
            router.include_router(room.router)
        return router

    def commands(self) -> list[click.Command]:
        return [commands.census, commands.earth]
