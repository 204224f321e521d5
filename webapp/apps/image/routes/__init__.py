"""The image app's routes, one module per resource, in one router (``app.router``):
what phones ask for and do first (most asked for), then the instructor's images,
lessons, the pyramids tiles fetch, hotspots and the quiz."""

from __future__ import annotations

from fastapi import APIRouter

from webapp.apps.image.routes import hotspots, images, lessons, phones, pyramids, quiz

router = APIRouter()
for resource in (phones, images, lessons, pyramids, hotspots, quiz):
    router.include_router(resource.router)
