"""The census data sets and colourings, for the dashboard (instructors only)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status
from pydantic import BaseModel, ConfigDict

from webapp.apps.census_map import pages
from webapp.apps.census_map.actions import (
    MapChanged,
    choose_surface,
    switch_dataset,
)
from webapp.apps.census_map.maps import census_maps
from webapp.apps.census_map.routes.common import colour_or_refuse
from webapp.apps.census_map.state import Surface
from webapp.apps.census_map.store import list_datasets, make_current
from webapp.choropleth.classes import Theme
from webapp.choropleth.palettes import SCHEMES, colours, kind
from webapp.core.threads import run_blocking
from webapp.database.connection import RowId
from webapp.web.deps import (
    ContextDep,
    StaffOnly,
    WallDep,
)
from webapp.web.problems import errors

router = APIRouter(tags=["census"])


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


@router.get("/api/apps/census/datasets", dependencies=[StaffOnly])
async def datasets(context: ContextDep) -> list[DataSetEntry]:
    infos = await run_blocking(list_datasets, context.db)
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


@router.post("/api/apps/census/current", dependencies=[StaffOnly], responses=errors(404))
async def choose_dataset(choice: DataSetChoice, context: ContextDep) -> DataSetChoice:
    """Make a data set the one the census map shows; walls showing it switch in sync."""
    try:
        await run_blocking(make_current, context.db, choice.dataset)
    except KeyError:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"There is no census data set {choice.dataset}."
        ) from None
    await switch_dataset(census_maps(context), context, choice.dataset)
    return choice


class ThemeChoice(BaseModel):
    """What a wall's tracts are coloured by (``null``: one plain colour)."""

    model_config = ConfigDict(extra="forbid")

    theme: Theme | None


@router.post(
    "/api/apps/census/walls/{wall_id}/theme", dependencies=[StaffOnly], responses=errors(404, 409)
)
async def choose_theme(wall: WallDep, choice: ThemeChoice, context: ContextDep) -> ThemeChoice:
    """Colour the wall's tracts by one of the data set's values (the dashboard); every
    tile changes in the same frame. 409 when the census map is not on the wall."""
    _, dataset = await pages.shown_dataset(census_maps(context), context, wall)
    await colour_or_refuse(context, wall, dataset, choice.theme)
    return choice


class SurfaceChoice(BaseModel):
    """Where the tiles draw the map: ``flat`` or on a ``globe``."""

    model_config = ConfigDict(extra="forbid")

    surface: Surface


@router.post(
    "/api/apps/census/walls/{wall_id}/surface", dependencies=[StaffOnly], responses=errors(409)
)
async def choose_wall_surface(
    wall: WallDep, choice: SurfaceChoice, context: ContextDep
) -> SurfaceChoice:
    """Draw the map flat or on a globe (the dashboard); every tile changes in the same
    frame, a tile without WebGL keeps the flat map. 409 when the census map is not on
    the wall."""
    try:
        await choose_surface(context, wall, choice.surface)
    except MapChanged:
        raise HTTPException(
            status.HTTP_409_CONFLICT, f"{wall.name} does not show the census map."
        ) from None
    return choice


class SchemeEntry(BaseModel):
    name: str
    kind: str
    colours: list[str]  # for five classes


@router.get("/api/apps/census/schemes", dependencies=[StaffOnly])
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


@router.get(
    "/api/apps/census/datasets/{dataset_id}", dependencies=[StaffOnly], responses=errors(404)
)
async def dataset_detail(dataset_id: RowId, context: ContextDep) -> DataSetDetail:
    """A data set's groups and values, for the dashboard's toggles and colouring."""
    dataset = await run_blocking(census_maps(context).dataset, context, dataset_id)
    if dataset is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no census data set {dataset_id}.")
    return DataSetDetail(
        id=dataset.id,
        title=dataset.title,
        tracts=len(dataset.tracts),
        groups=[GroupEntry(id=g.id, name=g.name, tracts=len(g.geoids)) for g in dataset.groups],
        attributes=[AttributeEntry(key=a.key, label=a.label) for a in dataset.settings.attributes],
    )
