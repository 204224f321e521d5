"""What the census map's routes share: the app of a request and the map view of a query."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, status
from pydantic import ValidationError

from wall_client.layout import Wall
from webapp.apps.census_map.actions import MapChanged, NoSuchValue, colour_wall
from webapp.apps.census_map.dataset import DataSet
from webapp.choropleth.classes import Theme
from webapp.engine.wall_state import View
from webapp.web.context import AppContext


def map_view(cx: float = 0.5, cy: float = 0.5, zoom: float = 1.0) -> View:
    """The view a tile asks for (its wall state's); 422 for one no view can be."""
    try:
        return View(center=(cx, cy), zoom=zoom)
    except ValidationError as error:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"view: {error.errors()[0]['msg']}"
        ) from None


MapViewDep = Annotated[View, Depends(map_view)]


async def colour_or_refuse(
    context: AppContext, wall: Wall, dataset: DataSet, theme: Theme | None
) -> None:
    """Colour the wall (:func:`colour_wall`), its refusals as answers: 404 for a value
    the data set lacks, 409 when the wall changed what it shows meanwhile."""
    try:
        await colour_wall(context, wall, dataset, theme)
    except NoSuchValue as missing:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"{dataset.title} has no value {str(missing)!r}."
        ) from None
    except MapChanged:
        raise HTTPException(
            status.HTTP_409_CONFLICT,
            f"{wall.name} changed what it shows meanwhile; look at the wall and try again.",
        ) from None
