"""Floors for the fan-out benchmark: the least a Python server does to deliver an event.

Two bare servers speak just enough of the tile protocol for ``benchmarks.fanout``'s
clients: a websocket at any path answers the client's ``hello`` with a
``{"type":"snapshot"}`` and is kept; ``POST /publish`` stamps the time and sends one
event, of the size of a tagwall light event, to every kept socket; ``GET /healthz``
answers 200 (what ``webapp.cli.testing.ServerProcess`` waits for).

* ``starlette_app``: Starlette under uvicorn, run as ``tagwall serve`` runs it
  (``python -m uvicorn benchmarks.floors:starlette_app --port P``), one ``send_text``
  per socket.
* ``python -m benchmarks.floors --port P``: the ``websockets`` library's own asyncio
  server and its ``broadcast()``, on uvloop when installed (as uvicorn picks it); the
  publish request is answered in ``process_request``.

And one for ``benchmarks.phone_steps``, the least a phone's page costs:

* ``fastapi_app``: a bare FastAPI page, ``GET /page``, with one dependency and one Jinja
  template of about 2 kB (autoescaped, a block of the template inherits a base, a loop),
  served as ``starlette_app`` is (``python -m uvicorn benchmarks.floors:fastapi_app``).

And one for ``benchmarks.image``, the least a pyramid tile costs to serve:

* ``static_app``: Starlette's ``StaticFiles`` over the folder ``FLOOR_STATIC_DIR`` names
  (``python -m uvicorn --factory benchmarks.floors:static_app``): each file at its path
  below it, as any static web server would send a stored image's tiles.

Nothing of tagwall is imported: a floor is what any server pays.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import os
import time
from http import HTTPStatus
from typing import Annotated

from fastapi import Depends, FastAPI
from fastapi.responses import HTMLResponse
from jinja2 import DictLoader, Environment, select_autoescape
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import PlainTextResponse
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect
from websockets.asyncio.server import ServerConnection, broadcast, serve
from websockets.http11 import Request as HandshakeRequest
from websockets.http11 import Response

APPLY_LEAD_MS = 250  # as benchmarks.fanout runs tagwall (TAGWALL_APPLY_LEAD_MS)
SNAPSHOT = json.dumps({"type": "snapshot"})
_versions = itertools.count(1)


def event_frame() -> str:
    """A light event stamped now, as ``webapp.engine.hub`` stamps one (whole server ms)."""
    apply_at = time.time_ns() // 1_000_000 + APPLY_LEAD_MS
    event = {
        "type": "event",
        "version": next(_versions),
        "changes": {"layers": {"grid": True}},
        "apply_at": apply_at,
    }
    return json.dumps(event, separators=(",", ":"))


# --- Starlette under uvicorn ------------------------------------------------------------

_tiles: set[WebSocket] = set()


async def _tile(websocket: WebSocket) -> None:
    await websocket.accept()
    await websocket.receive_text()  # hello
    await websocket.send_text(SNAPSHOT)
    _tiles.add(websocket)
    try:
        while True:
            await websocket.receive_text()
    except WebSocketDisconnect:
        pass
    finally:
        _tiles.discard(websocket)


async def _publish(request: Request) -> PlainTextResponse:
    frame = event_frame()
    for websocket in tuple(_tiles):
        await websocket.send_text(frame)
    return PlainTextResponse("ok\n")


async def _healthz(request: Request) -> PlainTextResponse:
    return PlainTextResponse("ok\n")


starlette_app = Starlette(
    routes=[
        Route("/publish", _publish, methods=["POST"]),
        Route("/healthz", _healthz),
        WebSocketRoute("/ws/{tile}", _tile),
    ]
)


# --- FastAPI with a Jinja page ---------------------------------------------------------

_PAGE_BASE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{% block title %}{% endblock %} - floor</title>
<link rel="stylesheet" href="/static/css/site.css">
<script type="importmap">{"imports": {"floor/": "/static/js/"}}</script>
</head><body>
<header><nav><a href="/">Home</a> <a href="/me">Me</a> <a href="/help">Help</a></nav></header>
<main>{% block main %}{% endblock %}</main>
<footer><p>A page as small as a phone's page is, rendered for {{ who }}.</p></footer>
</body></html>
"""
_PAGE = """{% extends "base.html" %}
{% block title %}Question {{ number }}{% endblock %}
{% block main %}
<h1>Question {{ number }} of {{ total }}</h1>
<p class="lead">What is the part of the brain this pin marks? Type its name: spelling
need not be perfect, and you can change your answer until you finish the quiz.</p>
<form method="post" action="/page/{{ number }}/answer" class="stack">
<input type="hidden" name="csrf" value="{{ csrf }}">
<label for="answer">Your answer</label>
<input id="answer" name="answer" value="{{ previous }}" autocomplete="off" required>
<button type="submit">Answer</button>
</form>
<ol class="progress">
{% for item in items %}<li class="{{ 'done' if item.done else 'open' }}">
<a href="/page/{{ item.number }}">Pin {{ item.number }}</a>{% if item.done %}
answered{% endif %}</li>
{% endfor %}</ol>
<p>You answered {{ items | selectattr("done") | list | length }} of {{ total }}.</p>
{% endblock %}
"""
_templates = Environment(
    loader=DictLoader({"base.html": _PAGE_BASE, "page.html": _PAGE}),
    autoescape=select_autoescape(default=True),
)
_ITEMS = [{"number": n, "done": n % 3 == 0} for n in range(1, 21)]


async def _visitor(request: Request) -> str:
    """The one dependency: what a page's dependency costs FastAPI to solve."""
    return request.headers.get("user-agent", "a phone")


fastapi_app = FastAPI()


@fastapi_app.get("/page", response_class=HTMLResponse)
async def _page(who: Annotated[str, Depends(_visitor)]) -> HTMLResponse:
    html = _templates.get_template("page.html").render(
        who=who, number=7, total=len(_ITEMS), csrf="x" * 43, previous="", items=_ITEMS
    )
    return HTMLResponse(html)


@fastapi_app.get("/healthz")
async def _fastapi_healthz() -> PlainTextResponse:
    return PlainTextResponse("ok\n")


# --- static files ---------------------------------------------------------------------

STATIC_DIR_ENV = "FLOOR_STATIC_DIR"


def static_app() -> Starlette:
    """The folder in ``FLOOR_STATIC_DIR`` as static files (a factory: uvicorn's process
    gets the folder from its environment, as ``tagwall serve`` gets its var folder)."""
    directory = os.environ[STATIC_DIR_ENV]
    return Starlette(
        routes=[Route("/healthz", _healthz), Mount("/", StaticFiles(directory=directory))]
    )


# --- the websockets library's own server ----------------------------------------------


async def serve_websockets(port: int) -> None:
    """Serve until killed."""
    tiles: set[ServerConnection] = set()

    async def tile(connection: ServerConnection) -> None:
        await connection.recv()  # hello
        await connection.send(SNAPSHOT)
        tiles.add(connection)
        try:
            await connection.wait_closed()
        finally:
            tiles.discard(connection)

    def plain_http(connection: ServerConnection, request: HandshakeRequest) -> Response | None:
        if request.path == "/publish":
            broadcast(tiles, event_frame())
            return connection.respond(HTTPStatus.OK, "ok\n")
        if request.path == "/healthz":
            return connection.respond(HTTPStatus.OK, "ok\n")
        return None  # a websocket handshake

    async with serve(tile, "127.0.0.1", port, process_request=plain_http) as server:
        await server.serve_forever()


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.floors", description=__doc__)
    parser.add_argument("--port", type=int, required=True)
    port = parser.parse_args().port
    try:
        import uvloop
    except ImportError:
        asyncio.run(serve_websockets(port))
    else:
        uvloop.run(serve_websockets(port))


if __name__ == "__main__":
    main()
