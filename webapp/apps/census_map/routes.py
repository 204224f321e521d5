"""The census map's pages and API: each tile's share of the map, the phone pages,
KML for Google Earth, and the data set the map shows."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, Annotated, Literal, cast

from fastapi import APIRouter, Depends, Form, HTTPException, Query, Request, Response, status
from fastapi.concurrency import run_in_threadpool
from pydantic import BaseModel, ConfigDict, ValidationError
from sqlalchemy import select

from wall_client.layout import Rect, Wall
from webapp.apps.census_map import pages
from webapp.apps.census_map.actions import (
    GroupHidden,
    MapChanged,
    NoRoom,
    NoSuchValue,
    colour_wall,
    group_shown,
    open_balloon,
    switch_dataset,
)
from webapp.apps.census_map.dataset import DataSet
from webapp.apps.census_map.earth import (
    DEFAULT_FOV,
    DEFAULT_MAP_REFRESH_S,
    DEFAULT_REFRESH_S,
    MAX_FOV,
    MAX_REFRESH_S,
    MIN_FOV,
    MIN_REFRESH_S,
    EarthOptions,
    caption_png,
    display_document,
    earth_displays,
    mounted_box,
    opener_kml,
    screen_role,
)
from webapp.apps.census_map.kml import census_kml, census_kmz, network_link_kml
from webapp.apps.census_map.legend import theme_view
from webapp.apps.census_map.mapview import tile_view, tract_boxes
from webapp.apps.census_map.rules import APP
from webapp.apps.census_map.store import list_datasets, make_current
from webapp.apps.census_map.theme import Shading, kept_theme
from webapp.caching import IMMUTABLE
from webapp.choropleth.classes import Method, Theme
from webapp.choropleth.palettes import SCHEMES, SchemeName, colours, kind
from webapp.database.connection import ROW_ID_MAX, RowId
from webapp.database.models import TagRecord
from webapp.deps import (
    ClientAddressDep,
    CsrfDep,
    PersonDep,
    ServicesDep,
    StaffOnly,
    StaffPageDep,
    TileDep,
    WallDep,
    limit_action,
)
from webapp.engine.wall_state import View, WallState, now_ms, read_state
from webapp.schemas import PlacedCode, errors
from webapp.services import Services
from webapp.templating import render

router = APIRouter(tags=["census"])
NETWORK_LINK_REFRESH_S = 10
KML_TYPE = "application/vnd.google-earth.kml+xml"
KMZ_TYPE = "application/vnd.google-earth.kmz"

if TYPE_CHECKING:
    from webapp.apps.census_map.app import CensusApp


def census_app(services: Services) -> CensusApp:
    return cast("CensusApp", services.apps[APP])


class DataSetChoice(BaseModel):
    model_config = ConfigDict(extra="forbid")

    dataset: RowId


class DataSetEntry(BaseModel):
    id: int
    name: str
    title: str
    tracts: int
    current: bool
    created_at: str


# --- tiles ---------------------------------------------------------------------------


def map_view(cx: float = 0.5, cy: float = 0.5, zoom: float = 1.0) -> View:
    """The view a tile asks for (its wall state's); 422 for one no view can be."""
    try:
        return View(center=(cx, cy), zoom=zoom)
    except ValidationError as error:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"view: {error.errors()[0]['msg']}"
        ) from None


MapViewDep = Annotated[View, Depends(map_view)]


@router.get("/api/walls/{wall_id}/tiles/{tile_id}/census", responses=errors(404))
async def tile_map(
    wall: WallDep,
    tile: TileDep,
    services: ServicesDep,
    dataset: RowId,
    view: MapViewDep,
    layout: Annotated[int, Query(ge=0, le=ROW_ID_MAX)] = 0,
) -> Response:
    """One tile's share of the census map for a data set, codes layout and view, in the
    tile's native pixels (the tile fetches it before it answers ``ready``)."""
    app = census_app(services)
    key = (dataset, wall.id, tile.id, layout, view.center, view.zoom)
    body = app.renders.get(key)
    if body is None:
        found = await run_in_threadpool(app.dataset, services, dataset)
        if found is None:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"There is no census data set {dataset}."
            )
        body = await run_in_threadpool(
            _tile_body, app, services, wall, tile.id, found.id, layout, view
        )
        app.renders.put(key, body)
    return Response(body, media_type="application/json")


def _tile_body(
    app: CensusApp,
    services: Services,
    wall: Wall,
    tile_id: str,
    dataset_id: int,
    layout_id: int,
    view: View,
) -> bytes:
    dataset = app.dataset(services, dataset_id)
    assert dataset is not None
    record = services.layout(wall.id, layout_id)
    placed = [PlacedCode.model_validate(p) for p in record.placed] if record else []
    codes = _census_tags(services, [p.code for p in placed])
    tracts = {tag.params["geoid"]: code for code, tag in codes.items() if tag.action == "tract"}
    occupied = [Rect(*p.footprint) for p in placed if p.display == tile_id]
    view_body = tile_view(dataset, app.geometry(dataset), wall, tile_id, view, tracts, occupied)
    view_body["toggles"] = {
        code: tag.params["group"] for code, tag in codes.items() if tag.action == "toggle"
    }
    clusters = {
        code: [str(g) for g in tag.params["geoids"]]
        for code, tag in codes.items()
        if tag.action == "cluster"
    }
    view_body["clusters"] = {
        code: sorted({dataset.group_of[g] for g in geoids if g in dataset.group_of})
        for code, geoids in clusters.items()
    }
    clustered = sum(len(geoids) for geoids in clusters.values())
    view_body["caption"] = (
        f"{dataset.title} · {len(tracts)} of {len(dataset.tracts)} tracts carry their own"
        f" code, {clustered} a shared one; every tract is in the tract index"
    )
    return json.dumps(view_body, separators=(",", ":")).encode()


def _census_tags(services: Services, codes: list[str]) -> dict[str, TagRecord]:
    """The census map's tags among ``codes`` (a layout's), by code."""
    if not codes:
        return {}
    with services.db.session() as session:
        rows = session.scalars(
            select(TagRecord).where(TagRecord.code.in_(codes), TagRecord.app == APP)
        )
        return {tag.code: tag for tag in rows}


@router.get("/api/walls/{wall_id}/tiles/{tile_id}/census/theme", responses=errors(404))
async def tile_theme(
    wall: WallDep,
    tile: TileDep,
    services: ServicesDep,
    dataset: RowId,
    attribute: Annotated[str, Query(max_length=64)],
    scheme: SchemeName,
    method: Method,
    classes: int,
    view: MapViewDep,
    layout: Annotated[int, Query(ge=0, le=ROW_ID_MAX)] = 0,
) -> Response:
    """The tracts' classes and the legend for the wall's theme (the state's ``theme``),
    the same for every tile of the wall: tiles fetch it before they answer ``ready``.
    The view says where the map lies, which the legend keeps off where it can."""
    try:
        theme = Theme(attribute=attribute, scheme=scheme, method=method, classes=classes)
    except ValidationError as error:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"theme: {error.errors()[0]['msg']}"
        ) from None
    app = census_app(services)
    key = ("theme", wall.id, dataset, layout, view.center, view.zoom, theme)
    body = app.renders.get(key)
    if body is None:
        found = await run_in_threadpool(app.dataset, services, dataset)
        if found is None:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"There is no census data set {dataset}."
            )
        if kept_theme(found, theme) is None:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"{found.title} has no value {attribute!r}."
            )
        body = await run_in_threadpool(_theme_body, app, services, wall, found, layout, view, theme)
        app.renders.put(key, body)
    return Response(body, media_type="application/json")


def _theme_body(
    app: CensusApp,
    services: Services,
    wall: Wall,
    dataset: DataSet,
    layout_id: int,
    view: View,
    theme: Theme,
) -> bytes:
    shading = app.shading(dataset, theme)
    assert shading is not None
    record = services.layout(wall.id, layout_id)
    codes = [
        Rect(*PlacedCode.model_validate(p).footprint) for p in (record.placed if record else [])
    ]
    on_map = tract_boxes(app.geometry(dataset), wall, view)
    body = theme_view(shading, dataset.id, [t.geoid for t in dataset.tracts], wall, codes, on_map)
    return body.model_dump_json().encode()


# --- phones --------------------------------------------------------------------------


@router.get("/apps/census/{wall_id}/tracts", include_in_schema=False)
async def tract_index(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep
) -> Response:
    """Every tract by group, each group with its toggle (a wall whose menu screen is
    too small for every toggle code still lets phones switch them)."""
    return await pages.index(census_app(services), request, services, wall)


@router.get("/apps/census/{wall_id}/tracts/{geoid}", include_in_schema=False)
async def tract_page(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, geoid: str
) -> Response:
    """The tract's two choices; its form needs the visitor's session (``person``)."""
    return await pages.tract_choice(census_app(services), request, services, wall, geoid)


@router.get("/apps/census/{wall_id}/tracts/{geoid}/here", include_in_schema=False)
async def tract_here(
    request: Request, wall: WallDep, services: ServicesDep, person: PersonDep, geoid: str
) -> Response:
    return await pages.tract_here(census_app(services), request, services, wall, geoid, person)


@router.post(
    "/apps/census/{wall_id}/tracts/{geoid}/balloon",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def show_on_wall(
    request: Request,
    wall: WallDep,
    services: ServicesDep,
    person: PersonDep,
    address: ClientAddressDep,
    geoid: str,
) -> Response:
    """ "Show on the wall": the tract's balloon opens beside it on every tile. 409, with
    the reason and what to do, when the wall hides the tract's group (the balloon would
    point at empty map) or has no room for it clear of every code."""
    app = census_app(services)
    _, dataset = await pages.shown_dataset(app, services, wall)
    tract = pages.tract_of(dataset, geoid)
    await limit_action(services, "balloon", person.visitor, address, wall.id)
    title = dataset.tract_title(tract)
    seconds = services.settings.balloon_seconds
    try:
        await open_balloon(app, services, wall, dataset, tract)
    except GroupHidden as hidden:
        return render(
            request,
            "census/tract.html",
            status.HTTP_409_CONFLICT,
            wall=wall,
            dataset=dataset,
            tract=tract,
            title=title,
            seconds=seconds,
            hidden=hidden.group,
            refused=True,
        )
    except NoRoom:
        return render(
            request,
            "census/balloon.html",
            status.HTTP_409_CONFLICT,
            wall=wall,
            tract=tract,
            title=title,
            placed=False,
            seconds=seconds,
        )
    return render(
        request,
        "census/balloon.html",
        wall=wall,
        tract=tract,
        title=title,
        placed=True,
        seconds=seconds,
    )


@router.post(
    "/apps/census/{wall_id}/groups/{group_id}/toggle",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def toggle_group(
    request: Request,
    wall: WallDep,
    services: ServicesDep,
    person: PersonDep,
    address: ClientAddressDep,
    group_id: str,
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """Flip a group from a phone page; ``tract``: the tract page it came from, which
    the answer leads back to."""
    _, dataset = await pages.shown_dataset(census_app(services), services, wall)
    actor = (person.visitor, address)
    back = dataset.tract(tract) if tract else None
    return await pages.toggled(request, services, wall, dataset, group_id, actor, back)


@router.post(
    "/apps/census/{wall_id}/theme",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def colour_from_phone(
    request: Request,
    wall: WallDep,
    services: ServicesDep,
    person: StaffPageDep,
    attribute: Annotated[str, Form(max_length=64)] = "",
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """An instructor's "colour the wall by this value" from a tract page (an empty
    ``attribute``: the plain map again); the wall's scheme, method and number of
    classes stay as they were. The answer leads back to ``tract``'s page."""
    app = census_app(services)
    state, dataset = await pages.shown_dataset(app, services, wall)
    theme = None
    if attribute:
        kept = state.theme  # its scheme, method and number of classes
        theme = (
            kept.model_copy(update={"attribute": attribute}) if kept else Theme(attribute=attribute)
        )
    await _colour(services, wall, dataset, theme)
    back = dataset.tract(tract) if tract else None
    shading = await run_in_threadpool(app.shading, dataset, theme)
    return render(
        request,
        "census/themed.html",
        wall=wall,
        shading=shading,
        back=back,
        back_title=dataset.tract_title(back) if back else None,
    )


async def _colour(services: Services, wall: Wall, dataset: DataSet, theme: Theme | None) -> None:
    """Colour the wall (:func:`colour_wall`), its refusals as answers: 404 for a value
    the data set lacks, 409 when the wall changed what it shows meanwhile."""
    try:
        await colour_wall(services, wall, dataset, theme)
    except NoSuchValue as missing:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"{dataset.title} has no value {str(missing)!r}."
        ) from None
    except MapChanged:
        raise HTTPException(
            status.HTTP_409_CONFLICT,
            f"{wall.name} changed what it shows meanwhile; look at the wall and try again.",
        ) from None


# --- Google Earth --------------------------------------------------------------------


async def _kml_inputs(services: Services, wall_id: str | None) -> tuple[Wall, WallState, CensusApp]:
    wall = services.walls.get(wall_id or services.settings.default_wall)
    if wall is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no wall {wall_id!r}.")
    _, state = await run_in_threadpool(read_state, services.db, wall.id)
    return wall, state, census_app(services)


@dataclass(frozen=True)
class _KmlInputs:
    dataset: DataSet
    hidden: frozenset[str]
    open_balloons: frozenset[str]
    name: str
    shading: Shading | None
    all_classes: bool = False  # Google Earth walls: a style for every class, see earth.py

    def kml(self) -> bytes:
        return census_kml(
            self.dataset,
            hidden=self.hidden,
            open_balloons=self.open_balloons,
            name=self.name,
            shading=self.shading,
            all_classes=self.all_classes,
        ).encode()

    def kmz(self) -> bytes:
        return census_kmz(
            self.dataset,
            hidden=self.hidden,
            open_balloons=self.open_balloons,
            name=self.name,
            shading=self.shading,
            all_classes=self.all_classes,
        )

    def cached(self, app: CensusApp, kind: Literal["kml", "kmz"]) -> bytes:
        """Built once per map state: a network link asks every few seconds."""
        theme = self.shading.theme if self.shading else None
        key = (
            kind,
            self.dataset.id,
            self.hidden,
            self.open_balloons,
            self.name,
            theme,
            self.all_classes,
        )
        body = app.renders.get(key)
        if body is None:
            body = self.kml() if kind == "kml" else self.kmz()
            app.renders.put(key, body)
        return body


@dataclass(frozen=True)
class _MapNow:
    """The map as the wall shows it now (the current data set as imported, plain, when
    the map is not on the wall, ``on_wall`` False)."""

    wall: Wall
    state: WallState
    dataset: DataSet
    on_wall: bool
    shading: Shading | None


async def _map_now(services: Services, wall_id: str | None) -> _MapNow:
    wall, state, app = await _kml_inputs(services, wall_id)
    dataset = await run_in_threadpool(app.shown, services, state)
    if dataset is None:
        dataset = await run_in_threadpool(app.datasets.current, services.db)
    if dataset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No census data set has been imported.")
    on_wall = state.app == APP and state.dataset == dataset.id
    shading = await run_in_threadpool(app.shading, dataset, state.theme) if on_wall else None
    return _MapNow(wall, state, dataset, on_wall, shading)


async def _kml_of(services: Services, wall_id: str | None) -> _KmlInputs:
    """The map as the wall shows it now: its data set, hidden groups, open balloons."""
    now_map = await _map_now(services, wall_id)
    wall, state, dataset, on_wall = now_map.wall, now_map.state, now_map.dataset, now_map.on_wall
    now = now_ms()
    hidden = frozenset(g.id for g in dataset.groups if not group_shown(state, g.id))
    balloons = frozenset(b.id.removeprefix("tract-") for b in state.balloons if b.open_at(now))
    return _KmlInputs(
        dataset=dataset,
        hidden=hidden if on_wall else frozenset(),
        open_balloons=balloons if on_wall else frozenset(),
        name=f"{dataset.title} · {wall.name}",
        shading=now_map.shading,
    )


WallQuery = Annotated[str | None, Query(alias="wall", max_length=64)]


@router.get("/apps/census/census.kml", responses=errors(404))
async def kml(services: ServicesDep, wall_id: WallQuery = None) -> Response:
    """The map as Google Earth shows it: tracts, groups as folders, open balloons."""
    inputs = await _kml_of(services, wall_id)
    body = await run_in_threadpool(inputs.cached, census_app(services), "kml")
    return Response(body, media_type=KML_TYPE)


@router.get("/apps/census/census.kmz", responses=errors(404))
async def kmz(services: ServicesDep, wall_id: WallQuery = None) -> Response:
    inputs = await _kml_of(services, wall_id)
    body = await run_in_threadpool(inputs.cached, census_app(services), "kmz")
    return Response(
        body,
        media_type=KMZ_TYPE,
        headers={"Content-Disposition": 'attachment; filename="census.kmz"'},
    )


@router.get("/apps/census/network-link.kml", responses=errors(404))
async def network_link(services: ServicesDep, wall_id: WallQuery = None) -> Response:
    """Open once in Google Earth Pro: it fetches census.kmz (a fifth of census.kml's
    bytes) every few seconds, so Earth follows the wall's groups and balloons."""
    wall, _, _ = await _kml_inputs(services, wall_id)
    url = f"{services.base_url}/apps/census/census.kmz?wall={wall.id}"
    text = network_link_kml(
        url, refresh_seconds=NETWORK_LINK_REFRESH_S, name=f"tagwall census map · {wall.name}"
    )
    return Response(
        text,
        media_type=KML_TYPE,
        headers={"Content-Disposition": 'attachment; filename="network-link.kml"'},
    )


# --- Google Earth walls: one Earth per display (see earth.py) -------------------------

FovQuery = Annotated[float, Query(ge=MIN_FOV, le=MAX_FOV)]
RefreshQuery = Annotated[int, Query(ge=MIN_REFRESH_S, le=MAX_REFRESH_S)]
OpenedQuery = Annotated[str | None, Query(alias="open", max_length=64)]
ColouredQuery = Annotated[str | None, Query(alias="theme", max_length=128)]


def _earth_display(wall: Wall, display_id: str) -> None:
    """404 unless ``display_id`` is one of the wall's displays Google Earth can drive."""
    if display_id not in {d.id for d in earth_displays(wall)}:
        role = screen_role(wall, display_id)
        detail = (
            f"Display {display_id!r} is the {role} screen: Google Earth cannot show its "
            "panels, open its tile in a browser."
            if role
            else f"Wall {wall.id!r} has no display {display_id!r}."
        )
        raise HTTPException(status.HTTP_404_NOT_FOUND, detail)


@router.get("/apps/census/earth/{wall_id}/map.kmz", responses=errors(404))
async def earth_map(wall: WallDep, services: ServicesDep) -> Response:
    """The map Google Earth walls load: census.kmz with no balloon open (each display
    opens the one on it) and a style for every class (each display recolours them)."""
    inputs = await _kml_of(services, wall.id)
    inputs = replace(inputs, open_balloons=frozenset(), all_classes=True)
    body = await run_in_threadpool(inputs.cached, census_app(services), "kmz")
    return Response(body, media_type=KMZ_TYPE)


@router.get("/apps/census/earth/{wall_id}/{display_id}.kml", responses=errors(404))
async def earth_opener(
    wall: WallDep,
    display_id: str,
    services: ServicesDep,
    fov: FovQuery = DEFAULT_FOV,
    refresh: RefreshQuery = DEFAULT_REFRESH_S,
    map_refresh: RefreshQuery = DEFAULT_MAP_REFRESH_S,
) -> Response:
    """What the Google Earth on one display opens: the map and its wall document."""
    _earth_display(wall, display_id)
    options = EarthOptions(fov=fov, refresh=refresh, map_refresh=map_refresh)
    return Response(
        opener_kml(services.base_url, wall, display_id, options),
        media_type=KML_TYPE,
        headers={"Content-Disposition": 'attachment; filename="tagwall-earth.kml"'},
    )


@router.get("/apps/census/earth/{wall_id}/{display_id}/wall.kml", responses=errors(404))
async def earth_display(
    request: Request,
    wall: WallDep,
    display_id: str,
    services: ServicesDep,
    fov: FovQuery = DEFAULT_FOV,
    opened: OpenedQuery = None,
    coloured: ColouredQuery = None,
) -> Response:
    """One display's wall document, fetched every few seconds by its Google Earth: the
    view, groups, balloon and colouring (an Update of the map) and the codes on the
    display. ``open`` and ``theme`` come from the previous document's cookie."""
    _earth_display(wall, display_id)
    shown = await _map_now(services, wall.id)
    app = census_app(services)
    geometry = await run_in_threadpool(app.geometry, shown.dataset)
    text = await run_in_threadpool(
        lambda: display_document(
            services.db,
            wall=shown.wall,
            state=shown.state,
            dataset=shown.dataset,
            geometry=geometry,
            on_wall=shown.on_wall,
            shading=shown.shading,
            shading_of=partial(app.shading, shown.dataset),
            display_id=display_id,
            fov=fov,
            opened=opened,
            coloured=coloured,
            base_url=str(request.base_url).rstrip("/"),  # as Earth reached us: targetHref
            now=now_ms(),
        )
    )
    return Response(text, media_type=KML_TYPE)


@router.get("/apps/census/earth/{wall_id}/captions/{layout_id}/{code}.png", responses=errors(404))
async def earth_caption(
    wall: WallDep, layout_id: RowId, code: str, services: ServicesDep
) -> Response:
    """A placed code's caption as Google Earth draws it under the code (a layout never
    changes, so neither does its image)."""
    record = await run_in_threadpool(services.layout, wall.id, layout_id)
    found = next((p for p in record.placed if p["code"] == code), None) if record else None
    placed = PlacedCode.model_validate(found) if found else None
    if placed is None or not placed.label or placed.caption is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such caption.")
    _, _, width, height = mounted_box(wall, placed.display, placed.caption)
    body = await run_in_threadpool(caption_png, placed.label, (width, height))
    return Response(body, media_type="image/png", headers={"Cache-Control": IMMUTABLE})


# --- data sets -----------------------------------------------------------------------


@router.get("/api/census/datasets", dependencies=[StaffOnly])
async def datasets(services: ServicesDep) -> list[DataSetEntry]:
    infos = await run_in_threadpool(list_datasets, services.db)
    return [
        DataSetEntry(
            id=i.id,
            name=i.name,
            title=i.title,
            tracts=i.tract_count,
            current=i.current,
            created_at=i.created_at.isoformat(),
        )
        for i in infos
    ]


@router.post("/api/census/current", dependencies=[StaffOnly], responses=errors(404))
async def choose_dataset(choice: DataSetChoice, services: ServicesDep) -> DataSetChoice:
    """Make a data set the one the census map shows; walls showing it switch in sync."""
    try:
        await run_in_threadpool(make_current, services.db, choice.dataset)
    except KeyError:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"There is no census data set {choice.dataset}."
        ) from None
    await switch_dataset(census_app(services), services, choice.dataset)
    return choice


class ThemeChoice(BaseModel):
    """What a wall's tracts are coloured by (``null``: one plain colour)."""

    model_config = ConfigDict(extra="forbid")

    theme: Theme | None


@router.post(
    "/api/census/walls/{wall_id}/theme", dependencies=[StaffOnly], responses=errors(404, 409)
)
async def choose_theme(wall: WallDep, choice: ThemeChoice, services: ServicesDep) -> ThemeChoice:
    """Colour the wall's tracts by one of the data set's values (the dashboard); every
    tile changes in the same frame. 409 when the census map is not on the wall."""
    _, dataset = await pages.shown_dataset(census_app(services), services, wall)
    await _colour(services, wall, dataset, choice.theme)
    return choice


class SchemeEntry(BaseModel):
    name: str
    kind: str
    colours: list[str]  # for five classes


@router.get("/api/census/schemes", dependencies=[StaffOnly])
async def schemes() -> list[SchemeEntry]:
    """The colour schemes the dashboard offers (ColorBrewer's colour-blind-safe ones)."""
    return [
        SchemeEntry(name=name, kind=kind(name), colours=list(colours(name, 5))) for name in SCHEMES
    ]


class AttributeEntry(BaseModel):
    key: str
    label: str


class GroupEntry(BaseModel):
    id: str
    name: str
    tracts: int


class DataSetDetail(BaseModel):
    id: int
    title: str
    tracts: int
    groups: list[GroupEntry]
    attributes: list[AttributeEntry]


@router.get("/api/census/datasets/{dataset_id}", dependencies=[StaffOnly], responses=errors(404))
async def dataset_detail(dataset_id: RowId, services: ServicesDep) -> DataSetDetail:
    """A data set's groups and values, for the dashboard's toggles and colouring."""
    dataset = await run_in_threadpool(census_app(services).dataset, services, dataset_id)
    if dataset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no census data set {dataset_id}.")
    return DataSetDetail(
        id=dataset.id,
        title=dataset.title,
        tracts=len(dataset.tracts),
        groups=[GroupEntry(id=g.id, name=g.name, tracts=len(g.geoids)) for g in dataset.groups],
        attributes=[AttributeEntry(key=a.key, label=a.label) for a in dataset.settings.attributes],
    )
