"""The ground under the census globe: imagery and terrain from a server of the site's
own (``TAGWALL_CENSUS_IMAGERY_URL``, ``TAGWALL_CENSUS_TERRAIN_URL``), over the bundled
Natural Earth II and the bare ellipsoid the globe always has.

Tiles do not ask the site's server themselves: this server relays its tiles from its
own origin (``routes/ground.py``). So the tiles' pages keep their Content-Security-
Policy (``'self'``, no other origin), the site's server needs no CORS headers (WebGL
refuses a picture from another origin without them), kiosks on a wall network that
reaches only tagwall still get the imagery, a picture several displays show is fetched
once (kept in memory), the site's server sees at most :data:`MAX_PARALLEL` requests at
once from a whole wall, and a server that does not answer is answered for at once
(:data:`RETRY_AFTER_FAILURE_S`) instead of leaving every tile waiting on it. The cost
is the server process passing each picture on (asynchronously, in the event loop).
"""

from __future__ import annotations

import asyncio
import logging
import re
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Literal
from urllib.parse import urlencode, urlsplit

import httpx
from pydantic import BaseModel, Field, ValidationError, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from webapp.core.caching import SizedCache
from webapp.core.settings import setting_problems

log = logging.getLogger(__name__)

Source = Literal["imagery", "terrain"]

IMAGERY_PATH = "/apps/census/globe/imagery"
TERRAIN_PATH = "/apps/census/globe/terrain"
MAX_ZOOM = 24  # a few centimetres per pixel: past any imagery server's finest level
MAX_PARALLEL = 8  # requests to the site's server at once, from every tile together
KEPT_BYTES = 64 * 1024 * 1024  # pictures and terrain tiles kept, per server process
MAX_TILE_BYTES = 8 * 1024 * 1024  # a tile larger than this is no tile
RETRY_AFTER_FAILURE_S = 30.0
"""After a server could not be reached or did not answer, how long its tiles are
refused at once (502/504) before it is asked again."""
KEEP_FOR = "public, max-age=86400"
"""Cache-Control of a relayed tile: kiosks keep it a day (a site's imagery changes
seldom; a restarted kiosk does not ask again)."""

WEB_MERCATOR_HALF_M = 20037508.342789244  # half the world's width in EPSG:3857 metres
PLACEHOLDER = re.compile(r"\{([^{}]*)\}")
TILE_PLACEHOLDERS = ("z", "x", "y", "-y", "bbox-epsg-3857")
TERRAIN_TILE = re.compile(r"^(?:[A-Za-z0-9_-]+/)*[A-Za-z0-9_-][A-Za-z0-9_.-]*$")
TERRAIN_QUERY = ("v", "extensions")  # what CesiumTerrainProvider adds to a tile's URL
TERRAIN_ACCEPT = "application/vnd.quantized-mesh,application/octet-stream;q=0.9,*/*;q=0.01"
TERRAIN_EXTENSIONS = ("octvertexnormals", "vertexnormals", "watermask", "metadata")
"""The quantized-mesh extensions a tile may ask for, in CesiumTerrainProvider's order."""
ASKED_EXTENSIONS = re.compile(r"extensions=([A-Za-z-]+)")
MEDIA_TYPES: dict[Source, tuple[frozenset[str], str]] = {
    "imagery": (frozenset({"image/png", "image/jpeg", "image/webp", "image/gif"}), "a picture"),
    "terrain": (
        frozenset(
            {"application/vnd.quantized-mesh", "application/octet-stream", "application/json"}
        ),
        "terrain",
    ),
}
"""What each server's answers may be (tiles; a tileset's layer.json), and what an answer
of any other type is not: an HTML page, a script or an SVG relayed from this origin
would be this server's own page."""


def _http_url(value: str) -> str:
    parts = urlsplit(value)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise ValueError(f"{value!r} is not an http:// or https:// URL")
    return value


class GroundSettings(BaseSettings):
    """The census app's own settings (``TAGWALL_CENSUS_*``): a site's imagery and
    terrain servers for the globe. Empty: the bundled Natural Earth II on the ellipsoid,
    nothing asked of any other server."""

    model_config = SettingsConfigDict(env_prefix="TAGWALL_CENSUS_", extra="ignore")

    imagery_url: str = ""
    terrain_url: str = ""
    tile_server_timeout: float = Field(default=5.0, gt=0, le=60)

    @field_validator("imagery_url", mode="after")
    @classmethod
    def _a_tile_template(cls, value: str) -> str:
        """A tile server's URL template (XYZ, TMS) or a WMS GetMap template, as tile
        servers and map clients (Leaflet, OpenLayers, MapLibre) write them."""
        if not value:
            return value
        _http_url(value)
        names = set(PLACEHOLDER.findall(value))
        unknown = sorted(names - set(TILE_PLACEHOLDERS))
        if unknown:
            raise ValueError(
                f"{{{unknown[0]}}} is not filled in by tagwall: a tile server's URL takes "
                "{z}, {x} and {y} ({-y} for TMS), a WMS's {bbox-epsg-3857}"
            )
        if not ({"z", "x"} <= names and names & {"y", "-y"}) and "bbox-epsg-3857" not in names:
            raise ValueError(
                f"{value!r} names no tile: give a tile server's URL with {{z}}, {{x}} and "
                "{y} (https://tiles.example.org/{z}/{x}/{y}.png) or a WMS GetMap URL with "
                "{bbox-epsg-3857}, SRS=EPSG:3857, WIDTH=256 and HEIGHT=256"
            )
        return value

    @field_validator("terrain_url", mode="after")
    @classmethod
    def _a_terrain_folder(cls, value: str) -> str:
        """The folder of a quantized-mesh tileset: its ``layer.json`` and tiles."""
        if not value:
            return value
        _http_url(value)
        if PLACEHOLDER.search(value) or urlsplit(value).query:
            raise ValueError(
                f"{value!r}: give the terrain tileset's folder, where its layer.json is "
                "(https://terrain.example.org/tiles/), not a tile's URL"
            )
        return value


def ground_settings() -> GroundSettings:
    """The census app's settings from the environment; ValueError naming each bad
    setting (``TAGWALL_CENSUS_IMAGERY_URL: ...``), so the server stops at start."""
    try:
        return GroundSettings()
    except ValidationError as error:
        raise ValueError("; ".join(setting_problems(error, GroundSettings))) from None


def terrain_accept(accept: str | None) -> str:
    """The ``Accept`` a terrain file is asked for with: CesiumTerrainProvider's, naming
    the extensions the tile's own ``Accept`` asks for. They are all of it that changes
    the site's answer, so the relay keeps one answer per extension set, however a
    client writes its header."""
    asked = ASKED_EXTENSIONS.search(accept or "")
    named = set(asked.group(1).split("-")) if asked else set()
    extensions = "-".join(e for e in TERRAIN_EXTENSIONS if e in named)
    if not extensions:
        return TERRAIN_ACCEPT
    return TERRAIN_ACCEPT.replace(",", f";extensions={extensions},", 1)


def imagery_tile_url(template: str, z: int, x: int, y: int) -> str:
    """The site's URL of the Web Mercator tile ``z/x/y`` (y from the north, as XYZ
    servers count; ``{-y}`` from the south, as TMS does)."""
    size = 2 * WEB_MERCATOR_HALF_M / 2**z
    west, north = -WEB_MERCATOR_HALF_M + x * size, WEB_MERCATOR_HALF_M - y * size
    values = {
        "z": str(z),
        "x": str(x),
        "y": str(y),
        "-y": str(2**z - 1 - y),
        "bbox-epsg-3857": ",".join(f"{v:.6f}" for v in (west, north - size, west + size, north)),
    }
    return PLACEHOLDER.sub(lambda match: values[match.group(1)], template)


class Ground(BaseModel):
    """What tiles lay over the bundled imagery and ellipsoid (None: nothing), as paths
    of this server (the relay): the globe data every tile fetches carries it."""

    imagery: str | None = None  # a URL template with {z}, {x}, {y} (Cesium's)
    terrain: str | None = None  # a quantized-mesh tileset's folder


@dataclass(frozen=True)
class Fetched:
    body: bytes
    media_type: str


class GroundUnavailable(Exception):
    """A tile the relay cannot give: ``status`` is what it answers (404 none there,
    502 the site's server failed, 504 it did not answer in time), ``reason`` why."""

    def __init__(self, status: int, reason: str) -> None:
        super().__init__(reason)
        self.status = status
        self.reason = reason


class GroundRelay:
    """The site's imagery and terrain servers, relayed: each tile asked once at a time
    (a picture asked for while it is being fetched waits for that fetch), kept in
    memory, at most :data:`MAX_PARALLEL` requests at once, and after a server could not
    be reached or timed out, its tiles refused at once for a while.

    ``transport`` replaces the network (tests: ``httpx.MockTransport``); ``clock``
    (seconds, monotonic) decides when a failed server is asked again."""

    def __init__(
        self,
        settings: GroundSettings,
        *,
        transport: httpx.AsyncBaseTransport | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.settings = settings
        self.kept = SizedCache[Fetched](KEPT_BYTES, lambda fetched: len(fetched.body))
        self._transport = transport
        self._clock = clock
        # by source: until when it is refused at once, and why (status, reason)
        self._down: dict[Source, tuple[float, GroundUnavailable]] = {}
        self._pending: dict[tuple[str, str], asyncio.Task[Fetched]] = {}
        # one client and limit per event loop (a test's app may run on several)
        self._session: (
            tuple[asyncio.AbstractEventLoop, httpx.AsyncClient, asyncio.Semaphore] | None
        ) = None

    def offered(self) -> Ground:
        """What the tiles lay over the bundled ground: this server's relay paths."""
        return Ground(
            imagery=f"{IMAGERY_PATH}/{{z}}/{{x}}/{{y}}" if self.settings.imagery_url else None,
            terrain=f"{TERRAIN_PATH}/" if self.settings.terrain_url else None,
        )

    async def imagery(self, z: int, x: int, y: int) -> Fetched:
        """The site's picture of Web Mercator tile ``z/x/y``."""
        url = imagery_tile_url(self.settings.imagery_url, z, x, y)
        return await self._once("imagery", url, "image/*")

    async def terrain(self, path: str, query: Mapping[str, str], accept: str | None) -> Fetched:
        """A file of the site's terrain tileset (``layer.json``, a tile): only paths
        under its folder, only the query CesiumTerrainProvider adds."""
        if ".." in path.split("/") or not TERRAIN_TILE.match(path):
            raise GroundUnavailable(404, f"{path!r} is no file of a terrain tileset")
        kept = urlencode([(k, query[k]) for k in TERRAIN_QUERY if k in query])
        base = self.settings.terrain_url.rstrip("/")
        url = f"{base}/{path}" + (f"?{kept}" if kept else "")
        return await self._once("terrain", url, terrain_accept(accept))

    # ------------------------------------------------------------------ fetching

    async def _once(self, source: Source, url: str, accept: str) -> Fetched:
        """``url`` asked with ``accept`` (one of a few: :func:`terrain_accept`), fetched
        once for every tile asking it at a time and kept."""
        key = (url, accept)
        kept = self.kept.get(key)
        if kept is not None:
            return kept
        loop = asyncio.get_running_loop()
        task = self._pending.get(key)
        if task is None or task.get_loop() is not loop:
            task = loop.create_task(self._fetch(source, url, accept))
            self._pending[key] = task
            task.add_done_callback(lambda done: self._settled(key, done))
        # a tile whose page went away does not cancel the fetch others wait for
        return await asyncio.shield(task)

    def _settled(self, key: tuple[str, str], task: asyncio.Task[Fetched]) -> None:
        if self._pending.get(key) is task:
            del self._pending[key]
        if not task.cancelled() and task.exception() is None:
            self.kept.put(key, task.result())

    def _now_session(self) -> tuple[httpx.AsyncClient, asyncio.Semaphore]:
        loop = asyncio.get_running_loop()
        if self._session is None or self._session[0] is not loop:
            client = httpx.AsyncClient(
                timeout=self.settings.tile_server_timeout,
                transport=self._transport,
                follow_redirects=False,  # not to another origin, which this server may reach
                limits=httpx.Limits(max_connections=MAX_PARALLEL),
            )
            self._session = (loop, client, asyncio.Semaphore(MAX_PARALLEL))
        return self._session[1], self._session[2]

    async def _fetch(self, source: Source, url: str, accept: str) -> Fetched:
        client, parallel = self._now_session()
        async with parallel:
            down = self._down.get(source)
            if down is not None and self._clock() < down[0]:
                raise GroundUnavailable(down[1].status, down[1].reason)  # resting: at once
            timeout = self.settings.tile_server_timeout
            try:
                async with asyncio.timeout(timeout):
                    fetched = await self._get(client, source, url, accept)
            except (TimeoutError, httpx.TimeoutException):
                raise self._failed(source, 504, f"did not answer within {timeout:g} s") from None
            except httpx.ConnectError as error:  # refused, unreachable, no such name
                raise self._failed(source, 502, f"could not be reached ({error})") from None
            except httpx.HTTPError as error:  # the connection dropped, a bad redirect ...
                raise self._failed(source, 502, f"failed ({error})") from None
        self._down.pop(source, None)
        return fetched

    def _failed(self, source: Source, status: int, what: str) -> GroundUnavailable:
        failure = GroundUnavailable(status, f"The site's {source} server {what}.")
        if source not in self._down:
            log.warning(
                "%s; the globe shows %s: asking again in %g s",
                failure.reason,
                "Natural Earth II there" if source == "imagery" else "the bare ellipsoid",
                RETRY_AFTER_FAILURE_S,
            )
        self._down[source] = (self._clock() + RETRY_AFTER_FAILURE_S, failure)
        return failure

    async def _get(
        self, client: httpx.AsyncClient, source: Source, url: str, accept: str
    ) -> Fetched:
        """One tile; GroundUnavailable for an answer that is none (a server answering
        at all is up: an error for one tile does not make it rest)."""
        async with client.stream("GET", url, headers={"Accept": accept}) as response:
            status = response.status_code
            if status in (204, 404):
                raise GroundUnavailable(404, f"The site's {source} server has no such tile.")
            if response.is_redirect:
                raise GroundUnavailable(
                    502,
                    f"The site's {source} server answered {status}, a redirect, which the "
                    "relay does not follow: set the address it leads to.",
                )
            if status != 200:
                raise GroundUnavailable(502, f"The site's {source} server answered {status}.")
            given = response.headers.get("content-type", "application/octet-stream")
            media_type = given.split(";")[0].strip().lower()
            allowed, what = MEDIA_TYPES[source]
            if media_type not in allowed:
                raise GroundUnavailable(
                    502, f"The site's {source} server answered {media_type}, not {what}."
                )
            body = bytearray()
            async for chunk in response.aiter_bytes():
                body += chunk
                if len(body) > MAX_TILE_BYTES:
                    raise GroundUnavailable(502, f"The site's {source} server sent too much.")
        return Fetched(bytes(body), media_type)
