"""The census map's phone pages and the reads they need: a tract (show on the wall, or
here), the tract index, a cluster's tracts. Values shown follow the visitor's
information class, and only ever that class's. What phones do (a balloon, a group
toggled, the colouring) is in ``routes/phones``; these pages write nothing."""

from __future__ import annotations

from fastapi import HTTPException, Request, Response, status
from sqlalchemy import select

from wall_client.layout import Wall
from webapp.apps.census_map.actions import group_shown, hidden_group
from webapp.apps.census_map.charts import charts_for
from webapp.apps.census_map.dataset import MARGINS_FROM, SHARES_FROM, DataSet, Tract
from webapp.apps.census_map.maps import CensusMaps
from webapp.apps.census_map.rules import APP, INDEX_TAG
from webapp.apps.census_map.state import CensusState
from webapp.apps.census_map.theme import Shading, describe
from webapp.apps.hooks import Scan
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import WallState
from webapp.people.person import Person
from webapp.web.context import AppContext
from webapp.web.templating import render


async def shown_dataset(
    app: CensusMaps, context: AppContext, wall: Wall
) -> tuple[WallState, DataSet]:
    """The data set on the wall; 409 when the census map is not on it now."""
    state = await context.state(wall)
    dataset = await run_blocking(app.shown, context, state) if state.app == APP else None
    if dataset is None:
        raise HTTPException(
            status.HTTP_409_CONFLICT, f"The census map is not on {wall.name} at the moment."
        )
    return state, dataset


def tract_of(dataset: DataSet, geoid: str) -> Tract:
    tract = dataset.tract(geoid)
    if tract is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"{dataset.title} has no tract {geoid!r}.")
    return tract


def index_code(context: AppContext, wall: Wall) -> str | None:
    """The tract index's code: publishing from a tract page goes through it."""
    with context.db.session() as session:
        return session.scalar(
            select(TagRecord.code).where(TagRecord.wall_id == wall.id, TagRecord.name == INDEX_TAG)
        )


async def tract_choice(
    app: CensusMaps, request: Request, context: AppContext, wall: Wall, geoid: str
) -> Response:
    """Show on the wall or here; while the wall hides the tract's group, the page says
    so and offers to show the group instead of a balloon pointing at empty map."""
    state, dataset = await shown_dataset(app, context, wall)
    tract = tract_of(dataset, geoid)
    return render(
        request,
        "census/tract.html",
        wall=wall,
        dataset=dataset,
        tract=tract,
        title=dataset.tract_title(tract),
        seconds=context.settings.balloon_seconds,
        hidden=hidden_group(state, dataset, tract),
    )


async def tract_here(
    app: CensusMaps, request: Request, context: AppContext, wall: Wall, geoid: str, person: Person
) -> Response:
    """The tract's values for this visitor's class, its charts, where it stands on the
    wall's colouring, and Publish; an instructor can colour the wall by a value here."""
    state, dataset = await shown_dataset(app, context, wall)
    tract = tract_of(dataset, geoid)

    def look_up() -> tuple[str | None, Shading | None]:  # one thread hop for both
        return index_code(context, wall), app.shading(dataset, CensusState.of(state).theme)

    code, shading = await run_blocking(look_up)
    return render(
        request,
        "census/here.html",
        wall=wall,
        dataset=dataset,
        tract=tract,
        title=dataset.tract_title(tract),
        facts=dataset.facts(tract, person.info_class),
        charts=charts_for(dataset, tract, person.info_class, app.chart_stats),
        info_class=person.info_class,
        margins_from=MARGINS_FROM,
        shares_from=SHARES_FROM,
        tag={"code": code} if code else None,
        subject=tract.geoid,
        shading=shading,
        fill=shading.colour(tract.geoid) if shading else None,
        standing=describe(shading, tract, person.info_class) if shading else [],
        colourable=dataset.settings.visible(person.info_class) if person.is_staff else [],
    )


async def index(app: CensusMaps, request: Request, context: AppContext, wall: Wall) -> Response:
    state, dataset = await shown_dataset(app, context, wall)
    by_group = [
        (
            group,
            [t for t in dataset.tracts if t.geoid in group.geoids],
            group_shown(state, group.id),
        )
        for group in dataset.groups
    ]
    return render(request, "census/index.html", wall=wall, dataset=dataset, groups=by_group)


async def cluster(app: CensusMaps, scan: Scan) -> Response:
    """A cluster code: the tracts under it, each a tap from its page (as the index)."""
    state, dataset = await shown_dataset(app, scan.context, scan.wall)
    geoids = [str(g) for g in scan.tag.params.get("geoids", [])]
    tracts = [t for g in geoids if (t := dataset.tract(g)) is not None]
    hidden = {t.geoid for t in tracts if hidden_group(state, dataset, t) is not None}
    return render(
        scan.request,
        "census/cluster.html",
        wall=scan.wall,
        dataset=dataset,
        tracts=tracts,
        hidden=hidden,
    )
