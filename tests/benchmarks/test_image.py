"""The image benchmark: its rule for which pyramid tiles a display fetches is the
layer's (``static/image.js``), and a tiny build and share fetch give the result's shape
(no times are checked; the runs themselves are ``make bench``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from benchmarks.floors import STATIC_DIR_ENV, static_app
from benchmarks.image import (
    TARGETS,
    build_pyramids,
    refine_figures,
    share,
    share_fetch,
    show,
    summary,
    synthesise,
)
from tests.conftest import operator_headers, wall_files
from tests.webapp.apps.image.samples import node_answer
from wall_client.config import load_wall
from webapp.apps.image.store import ImageManifest, deep_zoom_levels
from webapp.core.settings import Settings
from webapp.engine.wall_state import View

LAYER = Path(__file__).parents[2] / "webapp" / "apps" / "image" / "static" / "image.js"


def manifest(width: int, height: int) -> ImageManifest:
    return ImageManifest(
        id="0123456789ab",
        title="t",
        width=width,
        height=height,
        tile_size=512,
        levels=deep_zoom_levels(width, height),
        source="s.jpg",
        format="JPEG",
    )


def test_a_display_fetches_what_the_browser_test_saw_it_fetch() -> None:
    # tests/browser/test_image.py: a 4000 x 1120 px image at zoom 1 on the demo wall;
    # the left stage display fetched level 12's columns 0-3, the right one 3-7, all 3
    # rows (and the coarse level 9's one tile), the other displays nothing
    wall = load_wall(wall_files("demo")[0])
    image = manifest(4000, 1120)
    shares = {d.id: share(image, wall, d.id, View()) for d in wall.displays}
    for display, columns in [("r2c2", range(4)), ("r2c3", range(3, 8))]:
        assert shares[display][0] == (9, 0, 0)
        assert sorted(shares[display][1:]) == [(12, c, r) for c in columns for r in range(3)]
    assert not any(tiles for display, tiles in shares.items() if display not in {"r2c2", "r2c3"})


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node")
def test_the_share_rule_is_the_layers() -> None:
    cases = [
        ("hiperwall", manifest(20_000, 20_000), View()),
        ("hiperwall", manifest(20_000, 20_000), View(zoom=3, center=(0.5, 0.45))),
        ("hiperwall", manifest(30_000, 9_000), View(zoom=0.7, center=(0.3, 0.6))),
        ("demo", manifest(4000, 1120), View(zoom=1.25, center=(0.58, 0.5))),
    ]
    inputs, ours = [], []
    for wall_id, image, view in cases:
        wall = load_wall(wall_files(wall_id)[0])
        for display in wall.displays:
            viewport = wall.viewport(display.id)
            inputs.append(
                [
                    image.model_dump(),
                    list(wall.stage.xywh),
                    view.model_dump(),
                    list(viewport.scene_rect.xywh),
                    list(viewport.to_pixels[:2]),
                ]
            )
            ours.append([list(tile) for tile in share(image, wall, display.id, view)])
    # what the layer's draw() fetches for one display (its canvas at native size)
    script = f"""
        import {{Pyramid}} from {json.dumps(LAYER.as_uri())};
        const cases = {json.dumps(inputs)};
        console.log(JSON.stringify(cases.map(([manifest, stage, view, rect, [a, b]]) => {{
          const pyramid = new Pyramid(manifest);
          const placed = pyramid.placement(stage, view);
          const level = pyramid.levelFor(Math.hypot(a, b) * placed[0]);
          return [...new Set([pyramid.coarse, level])].flatMap((shown) =>
            pyramid.tilesIn(shown, placed, rect).map(([col, row]) => [shown, col, row]));
        }})));
    """
    layer = node_answer(script)
    assert len(layer) == len(ours) == 50 * 3 + 6
    assert sum(len(tiles) for tiles in ours) > 1000
    assert layer == ours


def test_a_tiny_run_builds_both_pyramids_and_fetches_every_share_from_both_servers(
    client: TestClient, settings: Settings, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    source = tmp_path / "source.jpg"
    synthesise(source, 512)
    build, image = build_pyramids(source, settings.var_dir / "images", tmp_path)
    assert (image.width, image.height, image.format) == (512, 512, "JPEG")
    every_tile = sum(cols * rows for cols, rows in map(image.tile_grid, range(image.levels)))
    assert build["store"]["tiles"] == build["dzsave_floor"]["tiles"] == every_tile
    assert len(build["dzsave_floor"]["runs_wall_s"]) == 2  # before and after the store's
    assert set(build["ratio"]) == {"wall_s", "cpu_s", "peak_rss_mb"}
    assert set(build["meets"]) == {"build_s", "peak_rss_mb"}

    pyramid = settings.var_dir / "images" / image.id / "pyramid_files"
    monkeypatch.setenv(STATIC_DIR_ENV, str(pyramid))
    view = show(client, operator_headers(client), "demo", image.id)
    with TestClient(static_app()) as floor:
        shares = share_fetch(client, floor, image, load_wall(wall_files("demo")[0]), view, 1)
    assert shares["displays_with_a_share"] == 2  # the demo's stage
    assert set(shares["displays"]) == {"r2c2", "r2c3"}
    assert shares["tiles_per_share"]["total"] == sum(
        d["tiles"] for d in shares["displays"].values()
    )
    assert (
        set(shares["ms"])
        == set(shares["floor_ms"])
        == set(shares["ratio"])
        == {
            "median",
            "p95",
            "max",
        }
    )
    assert isinstance(shares["meets_target"], bool)

    changes = [
        {
            "view": {"zoom": 2.0, "center": [0.5, 0.5]},
            "request_to_shown_ms": 600.0,
            "coarse_spread_ms": 3.0,
            "refine_ms": {"r2c2": 300.0, "r2c3": 1200.0},
            "refined": {"r2c2": "refined 11", "r2c3": "refined 11"},
            "server_cpu_s": 0.5,
            "browser_cpu_s": 1.0,
        },
        {
            "view": {"zoom": 1.0, "center": [0.4, 0.5]},
            "request_to_shown_ms": 500.0,
            "coarse_spread_ms": 9.0,
            "refine_ms": {"r2c2": 100.0, "r2c3": 200.0},
            "refined": {"r2c2": "refined 11", "r2c3": "refined 11"},
            "server_cpu_s": 0.5,
            "browser_cpu_s": 1.0,
        },
    ]
    refine = refine_figures(image, load_wall(wall_files("demo")[0]), [1.0, 2.0, 5.0], changes)
    assert refine["tiles"] == ["r2c2", "r2c3"]
    assert refine["coarse_spread_ms"] == {"median": 6.0, "max": 9.0}
    assert refine["light_change_spread_ms"] == {"median": 2.0, "max": 5.0}
    assert refine["coarse_spread_over_light_ms"] == 4.0
    fetched = sum(map(sum, refine["pyramid_tiles_per_change"].values()))
    assert refine["cpu_ms_per_pyramid_tile"] == {
        "server": round(1000 / fetched, 2),
        "browser": round(2000 / fetched, 2),
    }
    assert refine["refine_ms"] == {"median": 250.0, "p95": 1200.0, "max": 1200.0}
    assert refine["meets_target"] == {"coarse_spread_ms": True, "refine_ms": False}
    assert all(len(counts) == 2 for counts in refine["pyramid_tiles_per_change"].values())
    result = {
        "wall": "demo",
        "size_px": 512,
        "load_average_1min": [0.5, 1.0],
        "targets": TARGETS,
        "build": build,
        "share": shares,
        "refine": refine,
    }
    assert "dzsave floor" in summary(result)
