"""The census map as a wall app: the data set it shows, the codes on its tracts, its
pages and publications."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import click
from fastapi import APIRouter, Response

from wall_client.layout import Wall
from webapp.apps.census_map import commands, pages, routes
from webapp.apps.census_map.charts import charts_for
from webapp.apps.census_map.dataset import MOST_GROUPS
from webapp.apps.census_map.globe import map_projection
from webapp.apps.census_map.importer import seed
from webapp.apps.census_map.maps import CensusMaps
from webapp.apps.census_map.mapview import on_the_map, tract_codes
from webapp.apps.census_map.routes import phones
from webapp.apps.census_map.rules import APP, CENSUS_SET, INDEX_TAG
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.store import current_id, first_dataset
from webapp.apps.census_map.theme import kept_theme
from webapp.apps.hooks import Scan, WallApp, static_url
from webapp.engine.wall_state import WallState
from webapp.publishing.publication import Block, Publication
from webapp.tags.registry import (
    TagSpec,
    anchored_code_side_mm,
    anchored_footprint_mm,
    places_anchored,
)
from webapp.web.context import AppContext

FOLDER = Path(__file__).parent


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


class CensusApp(CensusMaps, WallApp):
    """The census map's :class:`~webapp.apps.hooks.WallApp`: its maps (data sets, their
    geometry and colouring) with what the core calls."""

    state = CensusState
    name: str = APP
    default_tag_set: str | None = CENSUS_SET
    layers: tuple[str, ...] = (f"{static_url(APP)}/census.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"

    def leave(self, state: WallState) -> WallState:
        """A tour playing stops (its driver ends at its next step)."""
        census = CensusState.of(state)
        tour = census.tour.stopped("the wall left the census map")
        return census.model_copy(update={"tour": tour}).put(state) if tour != census.tour else state

    def settle(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """On the wall, the map shows the current data set (the content folder's until
        an import): seeded on first use, so walls that never show the map pay nothing.
        The surface, camera and tour stay as they were kept; a tour still marked playing
        had its driver in a server that is gone (settle runs as a server starts, and as
        the map comes on a wall, which a tour's :meth:`leave` stopped): it stops, saying
        so."""
        dataset_id = current_id(context.db) or seed(context.db, first_dataset(context.settings))
        census = CensusState.of(state)
        theme = kept_theme(self.dataset(context, dataset_id), census.theme)
        tour = census.tour.stopped("the server restarted")
        return census.model_copy(update={"dataset": dataset_id, "theme": theme, "tour": tour}).put(
            state
        )

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """While the map is on the wall: the group toggles on the menu screen, the tract
        index on the registration screen, a code on every tract that has room for one
        at this view, and a cluster code over each neighbourhood of tracts too small
        for theirs, so every tract on the map is reached by pointing at the wall. The
        tracts stand where the wall shows them: flat, or on the globe where its camera,
        turned and tilted as it is, shows them (:func:`globe.map_projection`), their room
        for a code measured there."""
        dataset = self.shown(context, state) if state.app == APP else None
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
        geometry = self.geometry(dataset)
        codes = tract_codes(
            geometry,
            wall,
            state.view,
            anchored_code_side_mm(context.base_url, wall),
            anchored_footprint_mm(context.base_url, wall),
            mapping=map_projection(geometry, wall, state.view, *CensusState.of(state).camera),
        )
        # A code wanting to stand on a designated screen (a cluster's middle beside it)
        # may have its head under the panel's codes: its tracts join a cluster on the map.
        on_map = on_the_map(wall)

        def places(anchors: list[tuple[str, tuple[float, float]]]) -> set[str]:
            where = dict(anchors)
            placed = places_anchored(wall, context.base_url, anchors)
            return {key for key in placed if on_map(where[key])}

        codes = codes.settled(places)
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

    def screen_tags(self, wall: Wall) -> list[TagSpec]:
        """The tract index beside the registration codes and as many group toggles
        as a data set may have on the menu screen (labels are the data set's, the room
        they take is not)."""
        return [
            self._spec(INDEX_TAG, "Tract index", "index", {}, screen="registration", slot=2),
            *(
                self._spec(f"group-{n}", f"group {n}", "toggle", {}, screen="menu", slot=n)
                for n in range(1, MOST_GROUPS + 1)
            ),
        ]

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
            return await phones.toggle(self, scan)
        if action == "tract":
            return await pages.tract_choice(
                self, scan.request, scan.context, scan.wall, scan.tag.params.get("geoid", "")
            )
        if action == "cluster":
            return await pages.cluster(self, scan)
        return await pages.index(self, scan.request, scan.context, scan.wall)

    async def publication(self, scan: Scan) -> Publication | None:
        """The tract page as its publisher sees it: the values and charts of their class."""
        geoid = scan.subject or scan.tag.params.get("geoid")
        if not geoid:
            return None
        _, dataset, tract = await self.tract_on_wall(scan.context, scan.wall, geoid)
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

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "census/panel.html"

    def router(self) -> APIRouter | None:
        return routes.router

    def commands(self) -> list[click.Command]:
        return [commands.census, commands.earth]
