"""The volume API: stores on offer, each tile's image, the level-of-detail map, and
what happens to bad requests."""

from __future__ import annotations

import io
import json
from typing import Any
from urllib.parse import urlencode

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from tests.conftest import build_test_volume, services_of
from tests.conftest import operator_headers as operator
from webapp.engine.wall_state import read_state


@pytest.fixture
def volume(client: TestClient) -> str:
    return build_test_volume(services_of(client).settings)


def image_url(client: TestClient, scene: Any, **query: str) -> str:
    token = services_of(client).tile_token("demo")
    text = scene if isinstance(scene, str) else json.dumps(scene)
    query = {"scene": text, "token": token, **query}
    return f"/api/walls/demo/tiles/r2c3/volume?{urlencode(query)}"  # on the stage


def scene_of(volume: str, **layer: Any) -> dict[str, Any]:
    return {"view": {"yaw": 20, "pitch": 10}, "volume": {"volume": volume, **layer}}


def test_the_stores_on_offer(client: TestClient, volume: str) -> None:
    [info] = client.get("/api/volumes").json()
    assert info["name"] == volume
    assert info["shape"] == [40, 36, 28] and info["brick"] == 8


def test_a_tile_gets_its_refined_image_at_a_scale_it_can_stretch(
    client: TestClient, volume: str
) -> None:
    response = client.get(image_url(client, scene_of(volume)))
    assert response.status_code == 200
    assert response.headers["content-type"] == "image/png"
    scale = int(response.headers["x-pixel-scale"])
    assert response.headers["x-volume-level"] == "0"
    picture = Image.open(io.BytesIO(response.content))
    # a 1920 x 1080 tile: the image covers it at `scale` tile pixels per image pixel
    assert picture.size == (-(-1920 // scale), -(-1080 // scale))
    assert np.asarray(picture.convert("L")).max() > 100, "the blobs show"


def test_the_fallback_comes_from_the_coarse_level(client: TestClient, volume: str) -> None:
    response = client.get(image_url(client, scene_of(volume), detail="fallback"))
    assert response.status_code == 200
    meta = services_of(client).volumes.get(volume).meta
    assert response.headers["x-volume-level"] == str(meta.fallback_level)


def test_webp_on_request(client: TestClient, volume: str) -> None:
    response = client.get(image_url(client, scene_of(volume, mode="mip"), format="webp"))
    assert response.status_code == 200 and response.headers["content-type"] == "image/webp"
    assert Image.open(io.BytesIO(response.content)).format == "WEBP"


@pytest.mark.parametrize(
    "scene,message",
    [
        ("{not json", "scene: Invalid JSON"),
        ({"view": {}, "volume": {"volume": "blobs", "mode": "xray"}}, "scene: Input should be"),
        ({"view": {"zoom": 0}, "volume": {"volume": "blobs"}}, "scene: Input should be greater"),
        ({"view": {}}, "scene: Field required"),
        (
            {"view": {}, "volume": {"volume": "blobs", "clip": [[0.6, 0.4], [0, 1], [0, 1]]}},
            "clip along x must satisfy",
        ),
    ],
)
def test_a_malformed_scene_is_422_with_the_reason(
    client: TestClient, volume: str, scene: Any, message: str
) -> None:
    response = client.get(image_url(client, scene))
    assert response.status_code == 422
    assert message in response.json()["detail"]


def test_an_unknown_volume_is_404(client: TestClient, volume: str) -> None:
    response = client.get(image_url(client, scene_of("nothing")))
    assert response.status_code == 404
    assert "no volume called 'nothing'" in response.json()["detail"]


def test_an_unreadable_store_is_503_not_a_traceback(client: TestClient, volume: str) -> None:
    store = services_of(client).settings.resolved_volume_dir / volume
    (store / "bricks.npy").write_bytes(b"garbage")
    response = client.get(image_url(client, scene_of(volume)))
    assert response.status_code == 503
    assert "not a readable volume store" in response.json()["detail"]


def test_a_wall_takes_only_a_volume_that_exists(client: TestClient, volume: str) -> None:
    before = read_state(services_of(client).db, "demo")
    response = client.post(
        "/api/walls/demo/state", json={"volume": {"volume": "nothing"}}, headers=operator(client)
    )
    assert response.status_code == 422
    assert "no volume called 'nothing'" in response.json()["detail"]
    assert read_state(services_of(client).db, "demo") == before


def test_the_level_of_detail_map_follows_the_budget(client: TestClient, volume: str) -> None:
    headers = operator(client)
    assert client.get("/api/walls/demo/volume/detail", headers=headers).status_code == 404
    client.post("/api/walls/demo/state", json={"volume": {"volume": volume}}, headers=headers)
    detail = client.get("/api/walls/demo/volume/detail", headers=headers).json()
    assert detail["volume"] == volume and detail["budget"] == 1 << 24
    tiles = {t["tile_id"]: t for t in detail["tiles"]}
    assert set(tiles) == {"r1c1", "r1c2", "r1c3", "r2c1", "r2c2", "r2c3"}
    assert tiles["r2c3"]["level"] == 0 and tiles["r2c3"]["bricks"] > 0
    assert tiles["r1c1"]["bricks"] == 0, "the volume stands on the stage, r2c2 and r2c3"

    services_of(client).settings.volume_budget_voxels = 4_096  # one brick of 8^3 at most ...
    tight = client.get("/api/walls/demo/volume/detail", headers=headers).json()
    level = {t["tile_id"]: t for t in tight["tiles"]}["r2c3"]
    assert level["level"] > 0 and level["voxels"] <= 4_096  # ... so coarser levels


def test_a_repeated_request_is_served_from_the_render_cache(
    client: TestClient, volume: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = client.get(image_url(client, scene_of(volume)))
    renders: list[object] = []
    monkeypatch.setattr(
        "webapp.server.routes.volume.tile_image", lambda *args, **kw: renders.append(args)
    )
    again = client.get(image_url(client, scene_of(volume)))
    assert again.status_code == 200 and again.content == first.content
    assert again.headers["x-pixel-scale"] == first.headers["x-pixel-scale"]
    assert renders == [], "nothing was rendered again"
