"""The census map's phone pages and what phones do on the wall: a tract's page, its
balloon, a group shown or hidden, the colouring."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, Request, Response, status

from webapp.apps.census_map import pages
from webapp.apps.census_map.actions import (
    GroupHidden,
    NoRoom,
    OffTheWall,
    open_balloon,
)
from webapp.apps.census_map.maps import census_maps
from webapp.apps.census_map.routes.common import colour_or_refuse
from webapp.apps.census_map.state import CensusState
from webapp.choropleth.classes import Theme
from webapp.core.threads import run_blocking
from webapp.web.deps import (
    ClientAddressDep,
    ContextDep,
    CsrfDep,
    PersonDep,
    StaffPageDep,
    WallDep,
    limit_action,
)
from webapp.web.templating import render

router = APIRouter(tags=["census"])


@router.get("/apps/census/{wall_id}/tracts", include_in_schema=False)
async def tract_index(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep
) -> Response:
    """Every tract by group, each group with its toggle (a wall whose menu screen is
    too small for every toggle code still lets phones switch them)."""
    return await pages.index(census_maps(context), request, context, wall)


@router.get("/apps/census/{wall_id}/tracts/{geoid}", include_in_schema=False)
async def tract_page(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, geoid: str
) -> Response:
    """The tract's two choices; its form needs the visitor's session (``person``)."""
    return await pages.tract_choice(census_maps(context), request, context, wall, geoid)


@router.get("/apps/census/{wall_id}/tracts/{geoid}/here", include_in_schema=False)
async def tract_here(
    request: Request, wall: WallDep, context: ContextDep, person: PersonDep, geoid: str
) -> Response:
    return await pages.tract_here(census_maps(context), request, context, wall, geoid, person)


@router.post(
    "/apps/census/{wall_id}/tracts/{geoid}/balloon",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def show_on_wall(
    request: Request,
    wall: WallDep,
    context: ContextDep,
    person: PersonDep,
    address: ClientAddressDep,
    geoid: str,
) -> Response:
    """ "Show on the wall": the tract's balloon opens beside it on every tile. 409, with
    the reason and what to do, when the wall hides the tract's group (the balloon would
    point at empty map), looks away from the tract on its globe (beyond the wall's
    edge or over the horizon: it would point at nothing) or has no room for it clear
    of every code."""
    app = census_maps(context)
    _, dataset = await pages.shown_dataset(app, context, wall)
    tract = pages.tract_of(dataset, geoid)
    await limit_action(context, "balloon", person.visitor, address, wall.id)
    title = dataset.tract_title(tract)
    seconds = context.settings.balloon_seconds
    try:
        await open_balloon(app, context, wall, dataset, tract)
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
    except (OffTheWall, NoRoom) as refused:
        return render(
            request,
            "census/balloon.html",
            status.HTTP_409_CONFLICT,
            wall=wall,
            tract=tract,
            title=title,
            placed=False,
            off_the_wall=isinstance(refused, OffTheWall),
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
    context: ContextDep,
    person: PersonDep,
    address: ClientAddressDep,
    group_id: str,
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """Flip a group from a phone page; ``tract``: the tract page it came from, which
    the answer leads back to."""
    _, dataset = await pages.shown_dataset(census_maps(context), context, wall)
    actor = (person.visitor, address)
    back = dataset.tract(tract) if tract else None
    return await pages.toggled(request, context, wall, dataset, group_id, actor, back)


@router.post(
    "/apps/census/{wall_id}/theme",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def colour_from_phone(
    request: Request,
    wall: WallDep,
    context: ContextDep,
    person: StaffPageDep,
    attribute: Annotated[str, Form(max_length=64)] = "",
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """An instructor's "colour the wall by this value" from a tract page (an empty
    ``attribute``: the plain map again); the wall's scheme, method and number of
    classes stay as they were. The answer leads back to ``tract``'s page."""
    app = census_maps(context)
    state, dataset = await pages.shown_dataset(app, context, wall)
    theme = None
    if attribute:
        kept = CensusState.of(state).theme  # its scheme, method and number of classes
        theme = (
            kept.model_copy(update={"attribute": attribute}) if kept else Theme(attribute=attribute)
        )
    await colour_or_refuse(context, wall, dataset, theme)
    back = dataset.tract(tract) if tract else None
    shading = await run_blocking(app.shading, dataset, theme)
    return render(
        request,
        "census/themed.html",
        wall=wall,
        shading=shading,
        back=back,
        back_title=dataset.tract_title(back) if back else None,
    )
