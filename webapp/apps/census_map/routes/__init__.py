"""The census map's routes, one module per resource, in one router (``app.router``):
what phones ask for and do first (most asked for), then what tiles fetch, Google
Earth's documents, the data sets and colouring, the globe's camera and its ground."""

from __future__ import annotations

from fastapi import APIRouter

from webapp.apps.census_map.routes import camera, datasets, earth, ground, phones, tiles

router = APIRouter()
for resource in (phones, tiles, earth, datasets, camera, ground):
    router.include_router(resource.router)
