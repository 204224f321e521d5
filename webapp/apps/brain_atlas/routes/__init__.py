"""The brain atlas's routes, one module per resource, in one router (``app.router``):
what phones ask for and do first (most asked for), then the instructor's controls and
the quiz's rounds."""

from __future__ import annotations

from fastapi import APIRouter

from webapp.apps.brain_atlas.routes import control, phones, quiz

router = APIRouter()
for resource in (phones, control, quiz):
    router.include_router(resource.router)
