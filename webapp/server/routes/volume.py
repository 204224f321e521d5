"""Volumes on the wall: the built stores, each tile's image, the level-of-detail map."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Query, Response, status
from pydantic import ValidationError

from webapp.core.threads import run_blocking
from webapp.engine.wall_state import read_state
from webapp.server.deps import ServicesDep
from webapp.server.schemas import TileDetail, VolumeDetail, VolumeInfo, VolumeScene
from webapp.server.services import Services
from webapp.volume.store import VolumeStore, VolumeStoreError
from webapp.volume.tiles import (
    MEDIA_TYPES,
    Detail,
    EncodedTile,
    ImageFormat,
    encode,
    tile_image,
    tile_plan,
)
from webapp.web.deps import DetailedRenderAccess, StaffOnly, TileDep, WallDep
from webapp.web.problems import errors

router = APIRouter(tags=["volumes"])


def open_volume(services: Services, name: str) -> VolumeStore:
    """The store called ``name``, or the HTTP error that says why not."""
    try:
        return services.volumes.get(name)
    except KeyError:
        raise HTTPException(
            status.HTTP_404_NOT_FOUND,
            f"There is no volume called {name!r}; build one with `tagwall volume build`.",
        ) from None
    except VolumeStoreError as error:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(error)) from None


@router.get("/api/volumes")
def list_volumes(services: ServicesDep) -> list[VolumeInfo]:
    infos = []
    for name in services.volumes.names():
        try:
            meta = services.volumes.get(name).meta
        except (KeyError, VolumeStoreError):
            continue  # removed or half-copied meanwhile: not one to offer
        infos.append(VolumeInfo(**meta.model_dump(include=set(VolumeInfo.model_fields))))
    return infos


@router.get(
    "/api/walls/{wall_id}/tiles/{tile_id}/volume",
    dependencies=[DetailedRenderAccess],
    responses=errors(404),
)
async def tile_volume_image(
    wall: WallDep,
    tile: TileDep,
    services: ServicesDep,
    scene: Annotated[str, Query(max_length=4_000)],
    detail: Detail = "refined",
    image_format: Annotated[ImageFormat, Query(alias="format")] = "png",
) -> Response:
    """One tile's image of ``scene`` (JSON: the view and the volume layer); the tile
    stretches it over itself, ``X-Pixel-Scale`` tile pixels per image pixel."""
    try:
        asked = VolumeScene.model_validate_json(scene)
    except ValidationError as error:
        raise HTTPException(
            status.HTTP_422_UNPROCESSABLE_CONTENT, f"scene: {error.errors()[0]['msg']}"
        ) from None
    store = open_volume(services, asked.volume.volume)
    budget = services.settings.volume_budget_voxels
    scene_key = asked.model_dump_json()
    key = (store.name, store.stamp, wall.id, tile.id, scene_key, detail, budget, image_format)
    encoded = services.volumes.renders.get(key)
    if encoded is None:
        result = await run_blocking(
            tile_image, store, wall, tile.id, asked.view, asked.volume, detail=detail, budget=budget
        )
        body = await run_blocking(encode, result.image, image_format)
        encoded = EncodedTile(body, result.plan.level, result.plan.scale)
        services.volumes.renders.put(key, encoded)
    return Response(
        encoded.body,
        media_type=MEDIA_TYPES[image_format],
        headers={
            "X-Pixel-Scale": str(encoded.scale),
            "X-Volume-Level": str(encoded.level),
            "Cache-Control": "private, max-age=300",
        },
    )


@router.get("/api/walls/{wall_id}/volume/detail", dependencies=[StaffOnly], responses=errors(404))
async def volume_detail(wall: WallDep, services: ServicesDep) -> VolumeDetail:
    """Which level each tile shows for the wall's current view (refined)."""
    version, state = await run_blocking(read_state, services.db, wall.id)
    if state.volume is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "The wall shows no volume now.")
    store = open_volume(services, state.volume.volume)
    budget = services.settings.volume_budget_voxels
    layer, view = state.volume, state.view

    def plans() -> list[TileDetail]:
        details = []
        for display in wall.displays:
            _, _, plan = tile_plan(
                store, wall, display.id, view, layer, detail="refined", budget=budget
            )
            details.append(
                TileDetail(
                    tile_id=display.id,
                    level=plan.level,
                    bricks=plan.selection.count if plan.selection is not None else 0,
                    voxels=plan.voxels(store.meta),
                    pixel_scale=plan.scale,
                )
            )
        return details

    return VolumeDetail(
        wall=wall.id,
        version=version,
        volume=store.name,
        budget=budget,
        levels=store.meta.levels,
        fallback_level=store.meta.fallback_level,
        tiles=await run_blocking(plans),
    )
