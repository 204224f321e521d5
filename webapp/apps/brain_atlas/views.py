"""The brain atlas's view presets: where the wall looks at the brain, and how.

``content/brain_atlas/views.yaml`` lists them; each gives the wall's ``view`` (yaw,
pitch, zoom, centre) and the volume layer's fields (mode, transfer, clip, slice).
The volume itself comes from the app (:data:`VOLUME`). The presets are chosen so that
every region of every tag set shows in at least one of them; :func:`showing` computes
which (phones tell where to find a pin).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from wall_client.layout import Wall
from webapp.apps.brain_atlas.content import ATLAS_DIR, REGION_ID, ContentError, Region
from webapp.apps.brain_atlas.pins import (
    VOLUME,
    AtlasVolumes,
    PinCache,
    scene_pins,
)
from webapp.engine.wall_state import View, VolumeLayer

VIEWS_NAME = "views.yaml"
"""The presets' file in a content folder."""
VIEWS_FILE = ATLAS_DIR / VIEWS_NAME


class ViewPreset(BaseModel):
    """A view of the brain the dashboard offers: its ``view`` and volume layer."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(pattern=REGION_ID, max_length=64)
    name: str = Field(min_length=1, max_length=100)  # shown on the dashboard and phones
    view: View
    layer_fields: VolumeLayer = Field(alias="layer")

    @field_validator("layer_fields", mode="before")
    @classmethod
    def _volume_from_the_app(cls, value: Any) -> Any:
        if isinstance(value, dict):
            if "volume" in value:
                raise ValueError("leave `volume` out: the app says which volume it shows")
            return {**value, "volume": VOLUME}
        return value

    def layer(self, volume: str = VOLUME) -> VolumeLayer:
        """The wall's volume layer for this preset, showing ``volume``."""
        return self.layer_fields.model_copy(update={"volume": volume})


def load_views(path: Path = VIEWS_FILE) -> list[ViewPreset]:
    """The presets in ``path``, in order; ContentError listing every problem found."""
    name = path.name
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ContentError([f"{name}: missing"]) from None
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        raise ContentError([f"{name}: not valid YAML: {error}".replace("\n", " ")]) from error
    if not isinstance(data, dict) or not isinstance(data.get("views"), list):
        raise ContentError([f"{name}: expected a list under `views:`"])
    unknown = sorted(str(key) for key in data if key != "views")
    problems = [f"{name}: unknown key `{key}` (only `views:`)" for key in unknown]
    presets: list[ViewPreset] = []
    for index, item in enumerate(data["views"]):
        label = item.get("id", index) if isinstance(item, dict) else index
        try:
            presets.append(ViewPreset.model_validate(item))
        except ValidationError as error:
            for e in error.errors():
                where = ".".join(str(part) for part in e["loc"])
                problems.append(f"{name}: views[{label}]: {where}: {e['msg']}")
    seen: set[str] = set()
    for preset in presets:
        if preset.id in seen:
            problems.append(f"{name}: views[{preset.id}]: the id is used twice")
        seen.add(preset.id)
    if not presets and not problems:
        problems.append(f"{name}: no views: give at least one")
    if problems:
        raise ContentError(problems)
    return presets


def showing(
    presets: Sequence[ViewPreset],
    regions: Sequence[Region],
    volumes: AtlasVolumes,
    pins: PinCache,
    wall: Wall | None = None,
) -> dict[str, list[str]]:
    """Per region id, the ids of the presets that show its pin, the one where it shows
    largest first (none: an empty list). With ``wall`` a pin must also land on that
    wall (a zoomed preset may leave some off)."""
    found: dict[str, list[tuple[float, int, str]]] = {r.id: [] for r in regions}
    for order, preset in enumerate(presets):
        layer = preset.layer()
        plane = pins.get(volumes, regions, preset.view, layer)
        shown = set(plane)
        if wall is not None:
            shown &= set(scene_pins(plane, wall, preset.view, volumes.meta))
        for region_id in shown:
            found[region_id].append((-plane[region_id].area, order, preset.id))
    return {region_id: [p for *_, p in sorted(entries)] for region_id, entries in found.items()}
