"""The brain atlas's view presets: every region shows in one, and an editor who breaks
``views.yaml`` is told what is wrong in words they can act on."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from tag_service.placement import marks_of, pin_conflicts
from tests.webapp.apps.shipped_layouts import brain_layout
from wall_client.config import load_walls
from wall_client.layout import Wall
from webapp.apps.brain_atlas.content import ATLAS_DIR, ContentError, Region
from webapp.apps.brain_atlas.pins import VOLUME, AtlasVolumes, PinCache, scene_pins
from webapp.apps.brain_atlas.views import (
    VIEWS_FILE,
    ViewPreset,
    load_views,
    showing,
)
from webapp.core.settings import CONTENT_DIR
from webapp.engine.wall_state import VolumeLayer

COMFORTABLE = 100.0  # mm²: every region shows at least this large in its best preset


@pytest.fixture(scope="module")
def cache() -> PinCache:
    return PinCache()


def shipped_walls() -> list[tuple[str, Wall]]:
    walls = load_walls(sorted((CONTENT_DIR / "walls").glob("*.toml")))
    return sorted(walls.items())


# --- the presets in content/brain_atlas/views.yaml ---------------------------------


def test_the_presets_are_few_with_distinct_ids_and_names(presets: list[ViewPreset]) -> None:
    assert 4 <= len(presets) <= 6
    assert len({p.id for p in presets}) == len(presets)
    assert len({p.name for p in presets}) == len(presets)


def test_a_preset_layer_shows_the_volume_the_app_gives(presets: list[ViewPreset]) -> None:
    for preset in presets:
        assert preset.layer().volume == VOLUME
        layer = preset.layer("other")
        assert isinstance(layer, VolumeLayer) and layer.volume == "other"
        assert layer.model_dump(exclude={"volume"}) == preset.layer().model_dump(exclude={"volume"})


def test_every_region_of_both_sets_shows_in_a_preset(
    volumes: AtlasVolumes, regions: list[Region], presets: list[ViewPreset], cache: PinCache
) -> None:
    assert {s for r in regions for s in r.sets} == {"full", "k5"}
    shown = showing(presets, regions, volumes, cache)
    nowhere = sorted(region_id for region_id, where in shown.items() if not where)
    assert not nowhere, f"no preset shows {nowhere}"
    for region in regions:
        best = shown[region.id][0]
        preset = next(p for p in presets if p.id == best)
        area = cache.get(volumes, regions, preset.view, preset.layer())[region.id].area
        assert area >= COMFORTABLE, (region.id, best, area)


@pytest.mark.parametrize(("wall_id", "wall"), shipped_walls())
def test_every_region_has_its_pin_on_each_walls_scene(
    volumes: AtlasVolumes,
    regions: list[Region],
    presets: list[ViewPreset],
    cache: PinCache,
    wall_id: str,
    wall: Wall,
) -> None:
    """Zoomed presets leave the edges of the picture off the wall: the pins that
    matter still land on it."""
    shown = showing(presets, regions, volumes, cache, wall)
    nowhere = sorted(region_id for region_id, where in shown.items() if not where)
    assert not nowhere, f"{wall_id}: no pin on the scene for {nowhere}"


def test_showing_puts_the_largest_picture_first(
    volumes: AtlasVolumes, regions: list[Region], presets: list[ViewPreset], cache: PinCache
) -> None:
    by_id = {p.id: p for p in presets}
    shown = showing(presets, regions, volumes, cache)
    for region_id in ("insula", "hippocampus", "precentral-gyrus", "stem"):
        found = shown[region_id]
        assert found, region_id
        areas = [
            cache.get(volumes, regions, by_id[p].view, by_id[p].layer())[region_id].area
            for p in found
        ]
        assert areas == sorted(areas, reverse=True)
    assert "no-such-region" not in shown
    # the lateral surface is the side view's business, deep nuclei the slices'
    assert shown["supramarginal-gyrus"][0] == "left-side"
    assert "left-side" not in shown["putamen"]


# --- what an editor is told ----------------------------------------------------------


def write(tmp_path: Path, data: Any) -> Path:
    path = tmp_path / "views.yaml"
    path.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
    return path


def good() -> dict[str, Any]:
    return {
        "views": [
            {
                "id": "left-side",
                "name": "Left side",
                "view": {"yaw": -90, "pitch": 0, "zoom": 1.0},
                "layer": {"mode": "composite", "transfer": "tissue"},
            },
            {
                "id": "deep-axial",
                "name": "Deep structures, axial slice",
                "view": {"yaw": 0, "pitch": 90},
                "layer": {"mode": "slice", "slice": 0.1, "clip": [[0, 0.5], [0, 1], [0, 1]]},
            },
        ]
    }


def problems(path: Path) -> list[str]:
    with pytest.raises(ContentError) as caught:
        load_views(path)
    return caught.value.problems


def test_a_correct_file_loads(tmp_path: Path) -> None:
    presets = load_views(write(tmp_path, good()))
    assert [p.id for p in presets] == ["left-side", "deep-axial"]
    assert presets[0].view.yaw == -90 and presets[0].view.center == (0.5, 0.5)
    assert presets[1].layer().clip == ((0.0, 0.5), (0.0, 1.0), (0.0, 1.0))
    assert presets[1].layer().transfer == "grey"  # the layer's own default


def test_the_shipped_file_is_the_default() -> None:
    assert VIEWS_FILE == ATLAS_DIR / "views.yaml"
    assert [p.id for p in load_views()] == [p.id for p in load_views(VIEWS_FILE)]


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    assert problems(tmp_path / "views.yaml") == ["views.yaml: missing"]


def test_an_unknown_field_is_named_where_it_is(tmp_path: Path) -> None:
    data = good()
    data["views"][0]["colour"] = "red"
    data["views"][1]["layer"]["opacity"] = 0.5
    assert problems(write(tmp_path, data)) == [
        "views.yaml: views[left-side]: colour: Extra inputs are not permitted",
        "views.yaml: views[deep-axial]: layer.opacity: Extra inputs are not permitted",
    ]


def test_a_bad_yaw_is_named_with_its_range(tmp_path: Path) -> None:
    data = good()
    data["views"][0]["view"]["yaw"] = 400
    found = problems(write(tmp_path, data))
    assert found == [
        "views.yaml: views[left-side]: view.yaw: Input should be less than or equal to 360"
    ]


def test_bad_layer_values_are_named(tmp_path: Path) -> None:
    data = good()
    data["views"][0]["layer"]["mode"] = "xray"
    data["views"][1]["layer"]["clip"] = [[0.6, 0.5], [0, 1], [0, 1]]
    found = problems(write(tmp_path, data))
    assert len(found) == 2
    assert found[0].startswith("views.yaml: views[left-side]: layer.mode: Input should be")
    assert found[1].startswith("views.yaml: views[deep-axial]: layer: ")
    assert "clip along x must satisfy 0 <= low < high <= 1" in found[1]


def test_the_volume_is_not_for_the_file_to_choose(tmp_path: Path) -> None:
    data = good()
    data["views"][0]["layer"]["volume"] = "mni152"
    (found,) = problems(write(tmp_path, data))
    assert found.startswith("views.yaml: views[left-side]: layer: ")
    assert "leave `volume` out" in found


def test_missing_fields_and_repeated_ids_are_named(tmp_path: Path) -> None:
    data = good()
    del data["views"][0]["name"]
    data["views"][1]["id"] = "left-side"
    data["views"].append(dict(good()["views"][0]))
    found = problems(write(tmp_path, data))
    assert "views.yaml: views[left-side]: name: Field required" in found
    assert "views.yaml: views[left-side]: the id is used twice" in found


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("views: [\n", "views.yaml: not valid YAML"),
        ("", "views.yaml: expected a list under `views:`"),
        ("views: {a: 1}\n", "views.yaml: expected a list under `views:`"),
        ("views: []\n", "views.yaml: no views: give at least one"),
        ("views: []\nextra: 1\n", "views.yaml: unknown key `extra` (only `views:`)"),
    ],
)
def test_a_malformed_file_is_explained(tmp_path: Path, text: str, expected: str) -> None:
    assert problems(write(tmp_path, text))[0].startswith(expected)


@pytest.mark.parametrize(("wall_id", "wall"), shipped_walls())
def test_no_pin_crosses_another_or_hides_under_a_code_in_any_preset(
    volumes: AtlasVolumes,
    regions: list[Region],
    presets: list[ViewPreset],
    cache: PinCache,
    wall_id: str,
    wall: Wall,
) -> None:
    """Issue 31: in the deep views pin lines crossed and ran under other codes, so no
    one could tell which red head a code marks. A pin that finds no spot clear of the
    others is reported, with why; every region still gets its pin in some preset (the
    app orders its pins so, see pin_order)."""
    placed: dict[str, set[str]] = {"full": set(), "k5": set()}
    for preset in presets:
        plane = cache.get(volumes, regions, preset.view, preset.layer())
        points = scene_pins(plane, wall, preset.view, volumes.meta)
        for tag_set, standing in placed.items():
            pins = [(r.id, points[r.id]) for r in regions if tag_set in r.sets and r.id in points]
            layout = brain_layout(wall, pins)
            conflicts = [str(c) for c in pin_conflicts(marks_of(layout))]
            assert not conflicts, f"{wall_id} {preset.id} {tag_set}: {conflicts}"
            assert all(u.reason for u in layout.unplaced)
            standing |= {p.key for p in layout.placed}
    for tag_set, standing in placed.items():
        missing = sorted(r.id for r in regions if tag_set in r.sets and r.id not in standing)
        assert not missing, f"{wall_id} {tag_set}: no preset places a pin for {missing}"
