"""Hotspots as stored (validated, written whole) and where they stand on the wall: the
framing rule in Python, held to the layer's own numbers (``static/image.js``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.conftest import wall_files
from tests.webapp.apps.image.samples import node_answer
from wall_client.config import load_wall
from wall_client.layout import Rect
from webapp.apps.image import hotspots
from webapp.apps.image.hotspots import HOTSPOTS, HotspotFields, HotspotRefused, placement
from webapp.apps.image.store import LOCK, ImageManifest, ImageStore
from webapp.engine.wall_state import View

LAYER = Path(__file__).parents[4] / "webapp" / "apps" / "image" / "static" / "image.js"
CASES = [
    (4000, 1120, (100.0, 50.0, 2426.0, 680.0), View()),
    (20000, 20000, (1213.0, 680.0, 2426.0, 680.0), View(center=(0.45, 0.4), zoom=6)),
    (600, 400, (0.0, 0.0, 800.0, 900.0), View(center=(0.1, 0.9), zoom=0.5)),
]


def stored_image(root: Path, width: int = 600, height: int = 400) -> ImageManifest:
    """A stored image's manifest, without its pyramid (hotspots need only its size)."""
    manifest = ImageManifest(
        id="0123456789ab",
        title="Cell",
        width=width,
        height=height,
        tile_size=256,
        levels=11,
        source="cell.png",
        format="PNG",
    )
    (root / manifest.id).mkdir(parents=True)
    (root / manifest.id / "manifest.json").write_text(manifest.model_dump_json())
    return manifest


@pytest.mark.skipif(shutil.which("node") is None, reason="needs node")
def test_the_framing_rule_is_the_layers() -> None:
    script = f"""
        import {{Pyramid}} from {json.dumps(LAYER.as_uri())};
        const cases = {json.dumps([[w, h, s, v.model_dump()] for w, h, s, v in CASES])};
        console.log(JSON.stringify(cases.map(([width, height, stage, view]) =>
          new Pyramid({{id: "x", width, height, tile_size: 256, levels: 15}})
            .placement(stage, view))));
    """
    layer = node_answer(script)
    ours = [placement(w, h, Rect(*stage), view) for w, h, stage, view in CASES]
    assert len(layer) == len(CASES)
    for mine, theirs in zip(ours, layer, strict=True):
        assert mine == pytest.approx(tuple(theirs), abs=1e-9)


def test_a_hotspot_stands_where_the_image_is_drawn_and_only_on_the_wall() -> None:
    wall = load_wall(wall_files("demo")[0])
    image = ImageManifest(
        id="0123456789ab", title="t", width=4000, height=1120, tile_size=256, levels=13,
        source="s", format="PNG",
    )  # fmt: skip
    spots = [
        hotspots.Hotspot(id="a" * 12, x=0, y=0, title="corner"),
        hotspots.Hotspot(id="b" * 12, x=2000, y=560, title="middle"),
    ]
    stage = wall.stage
    whole = hotspots.wall_points(image, spots, wall, View())
    # about the stage's shape: as large as fits, its corner on the stage's edge
    corner = whole["a" * 12]
    assert stage.contains(corner)
    assert corner[0] == pytest.approx(stage.x) or corner[1] == pytest.approx(stage.y)
    assert whole["b" * 12] == pytest.approx(stage.center)
    # zoomed 4 about the middle: the corner leaves the wall, the middle stays
    zoomed = hotspots.wall_points(image, spots, wall, View(zoom=4))
    assert set(zoomed) == {"b" * 12}
    assert zoomed["b" * 12] == pytest.approx(stage.center)


def test_hotspots_are_validated_and_nothing_is_stored_on_error(tmp_path: Path) -> None:
    store = ImageStore(tmp_path)
    image = stored_image(tmp_path)
    file = tmp_path / image.id / HOTSPOTS
    spot = hotspots.add(
        store,
        image.id,
        HotspotFields(
            x=600, y=0, title=" Nucleus ", texts={"k5": "The *boss*."},
            question="What is this?", accepted=["nucleus"],
        ),
    )  # fmt: skip
    assert spot.title == "Nucleus" and hotspots.hotspots(store, image.id) == [spot]
    before = file.read_bytes()
    refused = [
        (HotspotFields(x=601, y=0, title="out"), "(601, 0) is outside the image (600 x 400 px)."),
        (HotspotFields(x=1, y=-1, title="out"), "(1, -1) is outside the image (600 x 400 px)."),
        (
            HotspotFields(x=1, y=1, title="q", question="Which?", accepted=[]),
            "A question needs at least one accepted answer.",
        ),
        (
            HotspotFields(x=1, y=1, title="a", accepted=["x"]),
            "Accepted answers need a question.",
        ),
    ]
    for fields, message in refused:
        with pytest.raises(HotspotRefused) as error:
            hotspots.add(store, image.id, fields)
        assert str(error.value) == message
        with pytest.raises(HotspotRefused):
            hotspots.edit(store, image.id, spot.id, fields)
    with pytest.raises(KeyError):
        hotspots.edit(store, image.id, "f" * 12, HotspotFields(x=1, y=1, title="x"))
    with pytest.raises(KeyError):
        hotspots.add(store, "ba0123456789", HotspotFields(x=1, y=1, title="x"))
    assert file.read_bytes() == before
    # no temporary file left behind (the lock file stays)
    assert {p.name for p in file.parent.iterdir()} == {"manifest.json", HOTSPOTS, LOCK}

    hotspots.delete(store, image.id, spot.id)
    assert hotspots.hotspots(store, image.id) == []


def test_each_group_reads_its_own_text_or_the_nearest() -> None:
    spot = HotspotFields(x=0, y=0, title="t", texts={"k5": "kids", "research": "deep"})
    assert spot.text_for("k5") == ("k5", "kids")
    assert spot.text_for("research") == ("research", "deep")
    assert spot.text_for("medical") == ("research", "deep")
    assert spot.text_for("undergraduate") == ("k5", "kids")
    assert HotspotFields(x=0, y=0, title="t").text_for("k5") is None
