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

Nothing of tagwall is imported: a floor is what any server pays.
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import time
from http import HTTPStatus

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import PlainTextResponse
from starlette.routing import Route, WebSocketRoute
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
