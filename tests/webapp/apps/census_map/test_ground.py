"""The globe's ground from the site's own servers: the settings (refused at start when
bad), the relay (kept, asked once, a failed server rested) and its routes, which keep
the tiles' Content-Security-Policy to this origin."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from importlib.metadata import entry_points

import httpx
import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient

from tests.conftest import services_of
from tests.webapp.apps.census_map.test_app import show_census
from webapp.apps.census_map.ground import (
    RETRY_AFTER_FAILURE_S,
    GroundRelay,
    GroundSettings,
    GroundUnavailable,
    ground_settings,
    imagery_tile_url,
)
from webapp.apps.census_map.state import CensusState
from webapp.apps.discovery import GROUP, AppLoadError, load_app
from webapp.cli.commands import main
from webapp.core.settings import PROJECT_ROOT

XYZ = "https://tiles.example.org/{z}/{x}/{y}.png"
PNG = b"\x89PNG\r\n\x1a\n" + b"picture" * 10


@pytest.mark.parametrize(
    "url",
    [
        XYZ,
        "http://10.0.0.5:8080/tms/1.0.0/ortho/{z}/{x}/{-y}.jpg",
        "https://gis.example.org/wms?SERVICE=WMS&REQUEST=GetMap&LAYERS=ortho&SRS=EPSG:3857"
        "&BBOX={bbox-epsg-3857}&WIDTH=256&HEIGHT=256&FORMAT=image/png",
    ],
)
def test_tile_servers_and_wms_are_accepted(url: str) -> None:
    assert GroundSettings(imagery_url=url).imagery_url == url


@pytest.mark.parametrize(
    ("variable", "value", "says"),
    [
        ("IMAGERY_URL", "ftp://tiles.example.org/{z}/{x}/{y}.png", "not an http:// or https://"),
        ("IMAGERY_URL", "tiles.example.org/{z}/{x}/{y}.png", "not an http:// or https://"),
        ("IMAGERY_URL", "https://tiles.example.org/ortho.png", "names no tile"),
        ("IMAGERY_URL", "https://tiles.example.org/{z}/{x}.png", "names no tile"),
        ("IMAGERY_URL", "https://{s}.tile.example.org/{z}/{x}/{y}.png", "{s} is not filled in"),
        ("TERRAIN_URL", "https://terrain.example.org/{z}/{x}/{y}.terrain", "layer.json"),
        ("TERRAIN_URL", "file:///srv/terrain", "not an http:// or https://"),
        ("TILE_SERVER_TIMEOUT", "0", "greater than 0"),
    ],
)
def test_a_bad_setting_is_refused_naming_it(
    monkeypatch: pytest.MonkeyPatch, variable: str, value: str, says: str
) -> None:
    monkeypatch.setenv(f"TAGWALL_CENSUS_{variable}", value)
    with pytest.raises(ValueError, match=f"^TAGWALL_CENSUS_{variable}: ") as refused:
        ground_settings()
    assert says in str(refused.value)


def test_a_bad_imagery_url_stops_the_server_at_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TAGWALL_CENSUS_IMAGERY_URL", "https://tiles.example.org/latest.png")
    census = next(e for e in entry_points(group=GROUP) if e.name == "census")
    with pytest.raises(AppLoadError, match=r"TAGWALL_CENSUS_IMAGERY_URL: .* names no tile"):
        load_app(census)
    result = CliRunner().invoke(main, ["serve"])
    assert result.exit_code == 2
    assert "TAGWALL_CENSUS_IMAGERY_URL" in result.output and "Traceback" not in result.output


def test_every_census_setting_is_documented() -> None:
    text = (PROJECT_ROOT / "docs" / "configuration.md").read_text()
    for name in GroundSettings.model_fields:
        assert f"`TAGWALL_CENSUS_{name.upper()}`" in text, name


def test_a_tile_is_asked_for_as_the_server_counts_it() -> None:
    assert imagery_tile_url(XYZ, 10, 165, 395) == "https://tiles.example.org/10/165/395.png"
    assert imagery_tile_url("http://t/{z}/{x}/{-y}", 3, 1, 2) == "http://t/3/1/5"
    west, south, east, north = map(float, imagery_tile_url("{bbox-epsg-3857}", 1, 1, 0).split(","))
    assert (west, south) == (0, 0) and east == north == pytest.approx(20037508.342789)


Handler = Callable[[httpx.Request], httpx.Response]


class Upstream:
    """A site's server as the relay meets it, counting what it is asked."""

    def __init__(self, handler: Handler) -> None:
        self.asked: list[httpx.Request] = []
        self.handler = handler
        self.now = 0.0

    def relay(self, **settings: object) -> GroundRelay:
        def answer(request: httpx.Request) -> httpx.Response:
            self.asked.append(request)
            return self.handler(request)

        fields: dict[str, object] = {"imagery_url": XYZ, **settings}
        return GroundRelay(
            GroundSettings.model_validate(fields),
            transport=httpx.MockTransport(answer),
            clock=lambda: self.now,
        )


def picture(_: httpx.Request) -> httpx.Response:
    return httpx.Response(200, content=PNG, headers={"content-type": "image/png"})


async def test_a_picture_is_asked_once_and_kept() -> None:
    upstream = Upstream(picture)
    relay = upstream.relay()
    together = await asyncio.gather(*(relay.imagery(3, 1, 2) for _ in range(5)))
    again = await relay.imagery(3, 1, 2)
    assert {t.body for t in together} == {PNG} and again.media_type == "image/png"
    assert [str(r.url) for r in upstream.asked] == ["https://tiles.example.org/3/1/2.png"]


@pytest.mark.parametrize(
    ("answer", "status", "says"),
    [
        (httpx.Response(404), 404, "no such tile"),
        (httpx.Response(500), 502, "answered 500"),
        (httpx.Response(200, text="<html>sign in</html>"), 502, "not a picture"),
    ],
)
async def test_a_server_that_answers_badly_is_refused_and_asked_again(
    answer: httpx.Response, status: int, says: str
) -> None:
    upstream = Upstream(lambda _: answer)
    relay = upstream.relay()
    for _ in range(2):
        with pytest.raises(GroundUnavailable) as refused:
            await relay.imagery(3, 1, 2)
        assert refused.value.status == status and says in refused.value.reason
    assert len(upstream.asked) == 2, "a server that answers is up: it is asked each time"


@pytest.mark.parametrize(
    ("error", "status", "says"),
    [
        (httpx.ConnectError("Connection refused"), 502, "could not be reached"),
        (httpx.ReadTimeout("slow"), 504, "did not answer within 5 s"),
    ],
)
async def test_a_server_that_does_not_answer_rests_before_it_is_asked_again(
    error: Exception, status: int, says: str
) -> None:
    def fail(_: httpx.Request) -> httpx.Response:
        raise error

    upstream = Upstream(fail)
    relay = upstream.relay(terrain_url="https://terrain.example.org/")
    for tile in ((3, 1, 2), (3, 1, 3), (4, 0, 0)):
        with pytest.raises(GroundUnavailable) as refused:
            await relay.imagery(*tile)
        assert refused.value.status == status and says in refused.value.reason
    assert len(upstream.asked) == 1, "tiles answered at once while the server rests"
    with pytest.raises(GroundUnavailable):  # terrain is another server: asked
        await relay.terrain("layer.json", {}, None)
    assert len(upstream.asked) == 2
    upstream.now += RETRY_AFTER_FAILURE_S + 1
    upstream.handler = picture
    assert (await relay.imagery(3, 1, 2)).body == PNG


async def test_terrain_passes_only_its_tileset_files_and_query() -> None:
    def mesh(_: httpx.Request) -> httpx.Response:
        return httpx.Response(
            200, content=b"mesh", headers={"content-type": "application/vnd.quantized-mesh"}
        )

    upstream = Upstream(mesh)
    relay = upstream.relay(terrain_url="https://terrain.example.org/sac/")
    accept = "application/vnd.quantized-mesh;extensions=watermask"
    query = {"v": "1.2.0", "token": "x", "extensions": "watermask&x=1"}
    tile = await relay.terrain("9/160/380.terrain", query, accept)
    assert tile.body == b"mesh"
    asked = upstream.asked[-1]
    assert str(asked.url) == (
        "https://terrain.example.org/sac/9/160/380.terrain?v=1.2.0&extensions=watermask%26x%3D1"
    )
    assert asked.headers["accept"] == accept
    for path in ("../secret", "9/../../x", "/etc/passwd", "https://elsewhere.example/x", ""):
        with pytest.raises(GroundUnavailable) as refused:
            await relay.terrain(path, {}, None)
        assert refused.value.status == 404
    assert len(upstream.asked) == 1


def with_ground(client: TestClient, handler: Handler, **settings: object) -> Upstream:
    """The app's relay on a pretend site server."""
    upstream = Upstream(handler)
    services_of(client).apps["census"].ground = upstream.relay(**settings)  # type: ignore[attr-defined]
    return upstream


def test_the_tiles_get_the_imagery_from_this_origin_under_the_usual_policy(
    client: TestClient,
) -> None:
    upstream = with_ground(client, picture, terrain_url="https://terrain.example.org/")
    state = show_census(client)
    dataset = CensusState.of(state).dataset
    globe = client.get(f"/api/apps/census/walls/demo/globe?dataset={dataset}&cx=0.5&cy=0.5&zoom=1")
    assert globe.json()["ground"] == {
        "imagery": "/apps/census/globe/imagery/{z}/{x}/{y}",
        "terrain": "/apps/census/globe/terrain/",
    }
    tile = client.get("/apps/census/globe/imagery/10/165/395")
    assert tile.status_code == 200 and tile.content == PNG
    assert tile.headers["content-type"] == "image/png"
    assert "max-age" in tile.headers["cache-control"]
    assert str(upstream.asked[0].url) == "https://tiles.example.org/10/165/395.png"
    token = services_of(client).tile_token("demo")
    page = client.get(f"/wall/demo/tile/r2c2?token={token}")
    policy = dict(
        part.strip().split(" ", 1) for part in page.headers["content-security-policy"].split(";")
    )
    # no other origin: the site's servers are reached through this one
    assert policy["img-src"] == "'self' data: blob:" and policy["connect-src"] == "'self'"
    assert "example.org" not in page.headers["content-security-policy"]

    assert client.get("/apps/census/globe/imagery/3/8/0").status_code == 404  # no such tile
    upstream.handler = lambda _: httpx.Response(503)
    failed = client.get("/apps/census/globe/imagery/10/165/396")
    assert failed.status_code == 502 and "answered 503" in failed.json()["detail"]
    assert failed.headers["cache-control"] == "no-store"


def test_without_a_site_server_nothing_is_relayed(client: TestClient) -> None:
    state = show_census(client)
    dataset = CensusState.of(state).dataset
    globe = client.get(f"/api/apps/census/walls/demo/globe?dataset={dataset}&cx=0.5&cy=0.5&zoom=1")
    assert globe.json()["ground"] == {"imagery": None, "terrain": None}
    for path in ("imagery/1/0/0", "terrain/layer.json"):
        answer = client.get(f"/apps/census/globe/{path}")
        assert answer.status_code == 404 and "TAGWALL_CENSUS_" in answer.json()["detail"]
