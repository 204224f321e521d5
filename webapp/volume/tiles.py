"""One tile's image of a volume, as the server hands it out: plan, render, encode."""

from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Literal

from PIL import Image as PILImage

from wall_client.layout import Wall
from webapp.engine.wall_state import View, VolumeLayer
from webapp.volume.render import (
    Camera,
    Footprint,
    Image,
    TilePlan,
    Voxels,
    fallback_plan,
    plan_tile,
    render,
)
from webapp.volume.store import VolumeStore

Detail = Literal["fallback", "refined"]
ImageFormat = Literal["png", "webp"]
MEDIA_TYPES: dict[ImageFormat, str] = {"png": "image/png", "webp": "image/webp"}


@dataclass(frozen=True)
class TileImage:
    image: Image
    plan: TilePlan


def tile_plan(
    store: VolumeStore,
    wall: Wall,
    display_id: str,
    view: View,
    layer: VolumeLayer,
    *,
    detail: Detail,
    budget: int,
) -> tuple[Camera, Footprint, TilePlan]:
    """What ``display_id`` renders: instantly from memory, or at its finest level."""
    camera = Camera.looking(store.meta, view.yaw, view.pitch)
    footprint = Footprint.of(wall.viewport(display_id), view, wall.stage, store.meta)
    if detail == "fallback":
        return camera, footprint, fallback_plan(store.meta, footprint)
    return camera, footprint, plan_tile(store, camera, footprint, layer, budget)


def tile_image(
    store: VolumeStore,
    wall: Wall,
    display_id: str,
    view: View,
    layer: VolumeLayer,
    *,
    detail: Detail,
    budget: int,
) -> TileImage:
    camera, footprint, plan = tile_plan(
        store, wall, display_id, view, layer, detail=detail, budget=budget
    )
    image = render(Voxels.of(store, plan), store.meta, camera, footprint, layer, plan.scale)
    return TileImage(image, plan)


def encode(image: Image, image_format: ImageFormat) -> bytes:
    """PNG (lossless, fast settings) or WebP (smaller, lossy)."""
    buffer = io.BytesIO()
    picture = PILImage.fromarray(image)
    if image_format == "webp":
        picture.save(buffer, "WEBP", quality=90, method=2)
    else:
        picture.save(buffer, "PNG", compress_level=1)
    return buffer.getvalue()


@dataclass(frozen=True)
class EncodedTile:
    body: bytes
    level: int
    scale: int
