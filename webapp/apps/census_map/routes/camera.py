"""The globe's camera and tours, for the dashboard (instructors only): turn and tilt,
fly to a place, keep a tour of views and play or stop it. Each change reaches every
tile at the wall clock's one instant."""

from __future__ import annotations

from typing import Annotated, Self

from fastapi import APIRouter, HTTPException, status
from pydantic import BaseModel, ConfigDict, Field, model_validator

from wall_client.layout import Wall
from webapp.apps.census_map import pages
from webapp.apps.census_map.actions import MapChanged, aim_camera, fly_to
from webapp.apps.census_map.globe import wall_middle
from webapp.apps.census_map.maps import census_maps
from webapp.apps.census_map.state import MAX_TOUR_STEPS, Heading, Tilt, Tour, TourStep
from webapp.apps.census_map.tours import NoTour, play_tour, save_tour, stop_tour
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import View
from webapp.web.deps import ContextDep, StaffOnly, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["census"])


def not_on_the_wall(wall: Wall) -> HTTPException:
    return HTTPException(status.HTTP_409_CONFLICT, f"{wall.name} does not show the census map.")


class CameraChoice(BaseModel):
    """How the globe's camera is turned (``heading``, degrees clockwise from north, 0 up
    to 360) and tilted from straight down (``tilt``, 0 to 60 degrees)."""

    model_config = ConfigDict(extra="forbid")

    heading: Heading
    tilt: Tilt


@router.post(
    "/api/apps/census/walls/{wall_id}/camera", dependencies=[StaffOnly], responses=errors(409)
)
async def aim_wall_camera(wall: WallDep, choice: CameraChoice, context: ContextDep) -> CameraChoice:
    """Turn and tilt the globe's camera (the dashboard); every tile changes in the same
    frame. A tour playing stops. 409 when the census map is not on the wall."""
    try:
        await aim_camera(context, wall, choice.heading, choice.tilt)
    except MapChanged:
        raise not_on_the_wall(wall) from None
    return choice


Latitude = Annotated[float, Field(ge=-85, le=85)]
Longitude = Annotated[float, Field(ge=-180, le=180)]


class FlyTo(BaseModel):
    """A place to look at from the middle of the wall: a tract (``tract``, its GEOID),
    a group of tracts (``group``: the middle of their extent), or ``longitude`` and
    ``latitude``; exactly one of them. ``zoom`` the view's zoom there (left out: the
    wall's own)."""

    model_config = ConfigDict(extra="forbid")

    tract: str | None = Field(default=None, min_length=1, max_length=32)
    group: str | None = Field(default=None, min_length=1, max_length=64)
    longitude: Longitude | None = None
    latitude: Latitude | None = None
    zoom: float | None = Field(default=None, gt=0, le=1_000)

    @model_validator(mode="after")
    def _one_place(self) -> Self:
        if (self.longitude is None) != (self.latitude is None):
            raise ValueError("give longitude and latitude together")
        given = [self.tract is not None, self.group is not None, self.longitude is not None]
        if sum(given) != 1:
            raise ValueError("give one place: a tract, a group, or longitude and latitude")
        return self


@router.post(
    "/api/apps/census/walls/{wall_id}/fly", dependencies=[StaffOnly], responses=errors(404, 409)
)
async def fly_wall(wall: WallDep, place: FlyTo, context: ContextDep) -> View:
    """Look at a place from the middle of the wall (the dashboard): the wall's view
    moves, so the flat map and the globe both go there, every tile in the same frame;
    answers the view. A tour playing stops. 404 for a tract or group the data set lacks,
    409 when the census map is not on the wall."""
    app = census_maps(context)
    _, dataset = await pages.shown_dataset(app, context, wall)
    geometry = await run_blocking(app.geometry, dataset)
    if place.tract is not None:
        index = geometry.geoids.index(place.tract) if place.tract in geometry.geoids else -1
        if index < 0:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"{dataset.title} has no tract {place.tract!r}."
            )
        u, v = (float(c) for c in geometry.label_points[index])
    elif place.group is not None:
        group = next((g for g in dataset.groups if g.id == place.group), None)
        if group is None:
            raise HTTPException(
                status.HTTP_404_NOT_FOUND, f"{dataset.title} has no group {place.group!r}."
            )
        boxes = [geometry.bounds[i] for i, g in enumerate(geometry.geoids) if g in group.geoids]
        u = (min(b[0] for b in boxes) + max(b[2] for b in boxes)) / 2
        v = (min(b[1] for b in boxes) + max(b[3] for b in boxes)) / 2
    else:
        assert place.longitude is not None and place.latitude is not None
        u, v = geometry.from_lonlat(place.longitude, place.latitude)
    try:
        return await fly_to(
            context, wall, geometry, wall_middle(wall), (float(u), float(v)), place.zoom
        )
    except MapChanged:
        raise not_on_the_wall(wall) from None


class TourSteps(BaseModel):
    """A tour: the views the wall plays, in order (at most 50)."""

    model_config = ConfigDict(extra="forbid")

    steps: list[TourStep] = Field(max_length=MAX_TOUR_STEPS)


@router.put(
    "/api/apps/census/walls/{wall_id}/tour", dependencies=[StaffOnly], responses=errors(409)
)
async def keep_tour(wall: WallDep, tour: TourSteps, context: ContextDep) -> Tour:
    """Keep the wall's tour (its steps; a tour playing stops). 409 when the census map
    is not on the wall."""
    try:
        return await save_tour(context, wall, tour.steps)
    except MapChanged:
        raise not_on_the_wall(wall) from None


@router.post(
    "/api/apps/census/walls/{wall_id}/tour/play", dependencies=[StaffOnly], responses=errors(409)
)
async def play_wall_tour(wall: WallDep, context: ContextDep) -> Tour:
    """Play the wall's tour from its first step, every step on every tile in the same
    frame. 409 when the census map is not on the wall or the tour has no steps."""
    try:
        return await play_tour(census_maps(context), context, wall)
    except MapChanged:
        raise not_on_the_wall(wall) from None
    except NoTour:
        raise HTTPException(
            status.HTTP_409_CONFLICT,
            f"{wall.name}'s tour has no steps: add views to it first.",
        ) from None


@router.post("/api/apps/census/walls/{wall_id}/tour/stop", dependencies=[StaffOnly])
async def stop_wall_tour(wall: WallDep, context: ContextDep) -> Tour:
    """Stop the wall's tour where it is (nothing to stop: the tour as it is)."""
    return await stop_tour(census_maps(context), context, wall)
