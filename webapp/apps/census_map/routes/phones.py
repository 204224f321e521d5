"""What phones ask for of the census map and what they do on the wall: a tract's pages
and the index (``pages``), a tract's balloon, a group shown or hidden (from a page or
a scanned toggle), an instructor's colouring. Each write is here, beside the route
that takes it, within the phones' limits."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, HTTPException, Request, Response, status

from wall_client.layout import Wall
from webapp.apps.census_map import pages
from webapp.apps.census_map.actions import (
    GroupHidden,
    NoRoom,
    OffTheWall,
    open_balloon,
    toggle_group,
)
from webapp.apps.census_map.dataset import DataSet, Tract
from webapp.apps.census_map.maps import CensusMaps, census_maps
from webapp.apps.census_map.routes.common import colour_or_refuse
from webapp.apps.census_map.state import CensusState
from webapp.apps.hooks import Scan
from webapp.choropleth.classes import Theme
from webapp.core.threads import run_blocking
from webapp.people.visitors import Visitor
from webapp.web.context import AppContext
from webapp.web.deps import CsrfDep, PhoneDep, StaffPhoneDep, limit_action
from webapp.web.templating import render

router = APIRouter(tags=["census"])


@router.get("/apps/census/{wall_id}/tracts", include_in_schema=False)
async def tract_index(request: Request, phone: PhoneDep) -> Response:
    """Every tract by group, each group with its toggle (a wall whose menu screen is
    too small for every toggle code still lets phones switch them)."""
    context = phone.context
    return await pages.index(census_maps(context), request, context, phone.wall)


@router.get("/apps/census/{wall_id}/tracts/{geoid}", include_in_schema=False)
async def tract_page(request: Request, phone: PhoneDep, geoid: str) -> Response:
    """The tract's two choices; its form needs the visitor's session (the phone's
    person)."""
    context = phone.context
    return await pages.tract_choice(census_maps(context), request, context, phone.wall, geoid)


@router.get("/apps/census/{wall_id}/tracts/{geoid}/here", include_in_schema=False)
async def tract_here(request: Request, phone: PhoneDep, geoid: str) -> Response:
    context = phone.context
    return await pages.tract_here(
        census_maps(context), request, context, phone.wall, geoid, phone.person
    )


@router.post(
    "/apps/census/{wall_id}/tracts/{geoid}/balloon",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def show_on_wall(request: Request, phone: PhoneDep, geoid: str) -> Response:
    """ "Show on the wall": the tract's balloon opens beside it on every tile. 409, with
    the reason and what to do, when the wall hides the tract's group (the balloon would
    point at empty map), looks away from the tract on its globe (beyond the wall's
    edge or over the horizon: it would point at nothing) or has no room for it clear
    of every code."""
    context, wall = phone.context, phone.wall
    app = census_maps(context)
    _, dataset = await pages.shown_dataset(app, context, wall)
    tract = pages.tract_of(dataset, geoid)
    await limit_action(context, "balloon", phone.person.visitor, phone.address, wall.id)
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
async def toggle_here(
    request: Request,
    phone: PhoneDep,
    group_id: str,
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """Flip a group from a phone page; ``tract``: the tract page it came from, which
    the answer leads back to."""
    context, wall = phone.context, phone.wall
    _, dataset = await pages.shown_dataset(census_maps(context), context, wall)
    actor = (phone.person.visitor, phone.address)
    back = dataset.tract(tract) if tract else None
    return await toggled(request, context, wall, dataset, group_id, actor, back)


async def toggle(app: CensusMaps, scan: Scan) -> Response:
    """A scanned group toggle flips that group on every tile at once."""
    _, dataset = await pages.shown_dataset(app, scan.context, scan.wall)
    group_id = str(scan.tag.params.get("group", ""))
    actor = (scan.visitor, scan.address)
    return await toggled(scan.request, scan.context, scan.wall, dataset, group_id, actor)


async def toggled(
    request: Request,
    context: AppContext,
    wall: Wall,
    dataset: DataSet,
    group_id: str,
    actor: tuple[Visitor, str],
    back: Tract | None = None,
) -> Response:
    """Flip a group for ``actor`` (a visitor at an address), within the wall's limits;
    the answer leads ``back`` to a tract page when the phone came from one."""
    group = next((g for g in dataset.groups if g.id == group_id), None)
    if group is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That tract group is not on the map now.")
    await limit_action(context, "toggle", *actor, wall.id)
    shown = await toggle_group(context, wall, group.id)
    return render(
        request,
        "census/toggled.html",
        wall=wall,
        group=group,
        shown=shown,
        back=back,
        back_title=dataset.tract_title(back) if back else None,
    )


@router.post(
    "/apps/census/{wall_id}/theme",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def colour_from_phone(
    request: Request,
    phone: StaffPhoneDep,
    attribute: Annotated[str, Form(max_length=64)] = "",
    tract: Annotated[str | None, Form(max_length=64)] = None,
) -> Response:
    """An instructor's "colour the wall by this value" from a tract page (an empty
    ``attribute``: the plain map again); the wall's scheme, method and number of
    classes stay as they were. The answer leads back to ``tract``'s page."""
    context, wall = phone.context, phone.wall
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
