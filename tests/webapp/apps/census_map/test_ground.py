"""The globe's ground from the site's own servers: the settings (refused at start when
bad), the relay (kept, asked once, a failed server rested) and its routes, which keep
the tiles' Content-Security-Policy to this origin."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib.metadata import entry_points

import httpx
import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient

from tests.conftest import services_of
from tests.webapp.apps.census_map.test_app import show_census
from webapp.apps.census_map.ground import (
    RETRY_AFTER_FAILURE_S,
    TERRAIN_ACCEPT,
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
    assert asked.headers["accept"] == (
        "application/vnd.quantized-mesh;extensions=watermask,"
        "application/octet-stream;q=0.9,*/*;q=0.01"
    )
    for path in ("../secret", "9/../../x", "/etc/passwd", "https://elsewhere.example/x", ""):
        with pytest.raises(GroundUnavailable) as refused:
            await relay.terrain(path, {}, None)
        assert refused.value.status == 404
    assert len(upstream.asked) == 1


Answer = tuple[int, dict[str, str], bytes]  # status, headers, body


class SiteServer:
    """A site's own tile server on a local port, over real HTTP: each path answered as
    ``answers`` says (anything else a PNG), counting what it is asked with which
    ``Accept``."""

    def __init__(self) -> None:
        self.answers: dict[str, Answer] = {}
        self.asked: list[tuple[str, str]] = []
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                server.asked.append((self.path, self.headers.get("Accept", "")))
                status, headers, body = server.answers.get(
                    self.path.split("?")[0], (200, {"Content-Type": "image/png"}, PNG)
                )
                self.send_response(status)
                for name, value in {**headers, "Content-Length": str(len(body))}.items():
                    self.send_header(name, value)
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, format: str, *args: object) -> None:
                pass

        self.http = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.http.server_address[1]}"
        threading.Thread(target=self.http.serve_forever, daemon=True).start()

    def relay(self) -> GroundRelay:
        """A relay of this server's imagery and its terrain tileset under /terrain/."""
        return GroundRelay(
            GroundSettings(
                imagery_url=f"{self.url}/{{z}}/{{x}}/{{y}}.png", terrain_url=f"{self.url}/terrain/"
            )
        )

    def close(self) -> None:
        self.http.shutdown()
        self.http.server_close()


@pytest.fixture
def site() -> Iterator[SiteServer]:
    server = SiteServer()
    yield server
    server.close()


@pytest.fixture
def elsewhere() -> Iterator[SiteServer]:
    """Another origin than the site's server (another port)."""
    server = SiteServer()
    yield server
    server.close()


async def test_a_redirect_is_followed_nowhere(site: SiteServer, elsewhere: SiteServer) -> None:
    """Not to another origin (the relay would fetch whatever the site's server names,
    from this server's network), nor within the site's own."""
    site.answers["/3/1/2.png"] = (302, {"Location": f"{elsewhere.url}/3/1/2.png"}, b"")
    site.answers["/terrain/layer.json"] = (301, {"Location": "/terrain/moved/layer.json"}, b"")
    relay = site.relay()
    with pytest.raises(GroundUnavailable) as refused:
        await relay.imagery(3, 1, 2)
    assert refused.value.status == 502
    assert refused.value.reason == (
        "The site's imagery server answered 302, a redirect, which the relay does not "
        "follow: set the address it leads to."
    )
    with pytest.raises(GroundUnavailable) as refused:
        await relay.terrain("layer.json", {}, None)
    assert refused.value.status == 502 and "answered 301, a redirect" in refused.value.reason
    assert elsewhere.asked == []
    assert [path for path, _ in site.asked] == ["/3/1/2.png", "/terrain/layer.json"]


def relayed(path: str) -> str:
    """This server's path of the site server's ``path`` (/3/1/2.png, /terrain/...)."""
    if path.startswith("/terrain/"):
        return f"/apps/census/globe{path}"
    return f"/apps/census/globe/imagery{path.removesuffix('.png')}"


@pytest.mark.parametrize(
    ("source", "path", "media_type", "what"),
    [
        ("imagery", "/3/1/2.png", "text/html; charset=utf-8", "a picture"),
        ("imagery", "/3/1/2.png", "image/svg+xml", "a picture"),
        ("terrain", "/terrain/layer.json", "text/html", "terrain"),
        ("terrain", "/terrain/9/160/380.terrain", "application/javascript", "terrain"),
    ],
)
def test_only_pictures_and_terrain_are_relayed_never_a_page(
    client: TestClient, site: SiteServer, source: str, path: str, media_type: str, what: str
) -> None:
    """A sign-in page, a script or an SVG (which runs script) from the site's server
    would be served as this server's own: a 502 with one line instead."""
    site.answers[path] = (200, {"Content-Type": media_type}, b"<html><script>steal()</script>")
    services_of(client).apps["census"].ground = site.relay()  # type: ignore[attr-defined]
    answer = client.get(relayed(path))
    assert answer.status_code == 502
    assert answer.headers["content-type"] == "application/json"
    kind = media_type.split(";")[0]
    assert answer.json() == {"detail": f"The site's {source} server answered {kind}, not {what}."}


@pytest.mark.parametrize(
    ("path", "media_type"),
    [
        ("/3/1/2.png", "image/png"),
        ("/3/1/2.png", "image/jpeg"),
        ("/3/1/2.png", "image/webp"),
        ("/terrain/layer.json", "application/json"),
        ("/terrain/9/160/380.terrain", "application/vnd.quantized-mesh;extensions=watermask"),
        ("/terrain/9/160/380.terrain", "application/octet-stream"),
    ],
)
def test_the_types_imagery_and_terrain_use_are_relayed(
    client: TestClient, site: SiteServer, path: str, media_type: str
) -> None:
    site.answers[path] = (200, {"Content-Type": media_type}, b"tile")
    services_of(client).apps["census"].ground = site.relay()  # type: ignore[attr-defined]
    answer = client.get(relayed(path))
    assert answer.status_code == 200 and answer.content == b"tile"
    assert answer.headers["content-type"] == media_type.split(";")[0]


def test_one_tile_is_fetched_once_however_its_accept_is_written(
    client: TestClient, site: SiteServer
) -> None:
    """The cache keys on the URL and the terrain extensions asked for (what changes the
    site's answer), not on the client's whole Accept header: 20 ways of writing it
    cost the site's server one request per extension set."""
    mesh = "application/vnd.quantized-mesh"
    site.answers["/terrain/9/160/380.terrain"] = (200, {"Content-Type": mesh}, b"mesh")
    services_of(client).apps["census"].ground = site.relay()  # type: ignore[attr-defined]
    tile = "/apps/census/globe/terrain/9/160/380.terrain"
    for number in range(20):
        accept = f"{mesh};extensions=octvertexnormals-watermask,*/*;q=0.0{number % 10}{number}"
        assert client.get(tile, headers={"Accept": accept}).status_code == 200
    for accept in ("text/html", "*/*", f"{mesh},application/octet-stream;q=0.9", ""):
        assert client.get(tile, headers={"Accept": accept}).status_code == 200
    for accept in ("image/webp,*/*", "image/png", "text/html"):
        assert client.get(relayed("/3/1/2.png"), headers={"Accept": accept}).is_success
    assert site.asked == [
        (
            "/terrain/9/160/380.terrain",
            f"{mesh};extensions=octvertexnormals-watermask,application/octet-stream;q=0.9,*/*;q=0.01",
        ),
        ("/terrain/9/160/380.terrain", TERRAIN_ACCEPT),
        ("/3/1/2.png", "image/*"),
    ]


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
