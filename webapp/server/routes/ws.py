"""Websockets of tiles (token, may report) and viewers (overview: receive only).

A connection starts with ``hello(last_version)``; the server answers with the
missed events when its history reaches back, otherwise with a snapshot, then
streams events from the bus. Bad frames close only this socket, with a policy code.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time

from fastapi import APIRouter, WebSocket
from pydantic import ValidationError
from sqlalchemy.exc import SQLAlchemyError
from starlette.websockets import WebSocketDisconnect, WebSocketState

from wall_client.layout import Wall
from webapp.database.connection import is_outage
from webapp.engine.bus.base import BusUnavailable, SubscriberTooSlow, Subscription
from webapp.engine.protocol import (
    CLIENT_MESSAGES,
    CLOSE_POLICY,
    CLOSE_TOO_BIG,
    CLOSE_TRY_AGAIN,
    Applied,
    Event,
    Hello,
    Ping,
    Pong,
    Ready,
    Snapshot,
    ViewportInfo,
)
from webapp.engine.wall_state import events_since, now_ms, read_state
from webapp.people.addresses import address_of
from webapp.people.security import token_matches
from webapp.server.deps import open_wall_socket
from webapp.server.services import Services

router = APIRouter()
log = logging.getLogger(__name__)

HELLO_TIMEOUT_S = 10.0
TOKEN_CHECK_S = 2.0  # how often an open tile socket checks that its token still holds


class CloseConnection(Exception):
    """Ends this connection with a websocket close code; nobody else is affected."""

    def __init__(self, code: int, reason: str) -> None:
        super().__init__(reason)
        self.code = code
        self.reason = reason


@router.websocket("/ws/wall/{wall_id}/tile/{tile_id}")
async def tile_socket(
    websocket: WebSocket, wall_id: str, tile_id: str, token: str | None = None
) -> None:
    if (opened := await open_wall_socket(websocket, wall_id, tile_id)) is None:
        return
    services, wall = opened
    if not token_matches(services.tile_token(wall_id), token):
        await websocket.close(CLOSE_POLICY, "bad tile token")
        return
    await Connection(websocket, services, wall, tile_id, token).serve()


@router.websocket("/ws/wall/{wall_id}/view")
async def viewer_socket(websocket: WebSocket, wall_id: str) -> None:
    if (opened := await open_wall_socket(websocket, wall_id)) is None:
        return
    services, wall = opened
    await Connection(websocket, services, wall, None).serve()


class Connection:
    """One tile's (or viewer's) socket: a reader and a writer sharing a send lock."""

    def __init__(
        self,
        websocket: WebSocket,
        services: Services,
        wall: Wall,
        tile_id: str | None,
        token: str | None = None,
    ) -> None:
        self.websocket = websocket
        self.services = services
        self.hub = services.hub
        self.wall = wall
        self.tile_id = tile_id
        self.token = token
        self.send_lock = asyncio.Lock()

    async def serve(self) -> None:
        try:
            hello = await asyncio.wait_for(self.receive(), HELLO_TIMEOUT_S)
            if not isinstance(hello, Hello):
                raise CloseConnection(CLOSE_POLICY, "the first frame must be hello")
            async with self.hub.bus.subscribe(self.wall.id) as subscription:
                await self.catch_up(hello)
                if self.tile_id:
                    await self.hub.tile_connected(
                        self.wall.id, self.tile_id, address_of(self.websocket)
                    )
                try:
                    await self.pump(subscription)
                finally:
                    if self.tile_id:
                        await self.hub.tile_disconnected(self.wall.id, self.tile_id)
        except CloseConnection as close:
            await self.close(close.code, close.reason)
        except TimeoutError:
            await self.close(CLOSE_POLICY, "no hello in time")
        except WebSocketDisconnect:
            pass  # the peer went away; nothing to tell it
        except BusUnavailable as error:
            log.warning("tile socket of %s: %s", self.wall.id, error)
            await self.close(CLOSE_TRY_AGAIN, "the event bus is not answering: reconnect")
        except SQLAlchemyError as error:
            if not is_outage(error):
                raise
            log.warning("tile socket of %s: the database is not answering", self.wall.id)
            await self.close(CLOSE_TRY_AGAIN, "the database is not answering: reconnect")

    async def catch_up(self, hello: Hello) -> None:
        """Replay what the tile missed, or send a snapshot when history is too short or
        a missed change was heavy: the tile loads what a snapshot needs (renders, code
        layouts) before showing it, which a replayed event, shown as it comes, skips."""
        db, wall_id = self.services.db, self.wall.id
        if hello.last_version is not None:
            replay = await self.hub.run_sync(events_since, db, wall_id, hello.last_version)
            if replay is not None and not any(change.heavy for change in replay):
                for change in replay:
                    event = Event(version=change.version, changes=change.changes, apply_at=0)
                    await self.send(event.model_dump_json())
                return
        version, state = await self.hub.run_sync(read_state, db, wall_id)
        viewport = ViewportInfo.of(self.wall.viewport(self.tile_id)) if self.tile_id else None
        snapshot = Snapshot(
            wall=wall_id,
            version=version,
            state=state.model_dump(mode="json"),
            server_time=now_ms(),
            viewport=viewport,
        )
        await self.send(snapshot.model_dump_json())

    async def pump(self, subscription: Subscription) -> None:
        """Run reader and writer until either ends; the other is cancelled."""
        tasks = {
            asyncio.create_task(self.read_loop()),
            asyncio.create_task(self.write_loop(subscription)),
        }
        if self.tile_id:
            tasks.add(asyncio.create_task(self.watch_token()))
        try:
            done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in tasks:
                task.cancel()
            for task in tasks:
                with contextlib.suppress(asyncio.CancelledError):
                    await task
        for task in done:
            task.result()

    async def read_loop(self) -> None:
        while True:
            message = await self.receive()
            received = time.time_ns() / 1e6
            if isinstance(message, Ping):
                async with self.send_lock:
                    pong = Pong(t0=message.t0, t1=received, t2=time.time_ns() / 1e6)
                    await self.websocket.send_text(pong.model_dump_json())
                continue
            if isinstance(message, Hello):
                await self.catch_up(message)
                continue
            if self.tile_id is None:
                raise CloseConnection(CLOSE_POLICY, f"viewers may not send {message.type}")
            if isinstance(message, Ready):
                await self.hub.tile_ready(self.wall.id, self.tile_id, message.version)
            elif isinstance(message, Applied):
                await self.hub.tile_applied(
                    self.wall.id, self.tile_id, message.version, message.server_time, message.notes
                )

    async def watch_token(self) -> None:
        """A tile whose token was rotated (``tagwall tokens rotate tiles``) is closed:
        the old URL is worth nothing from then on, open or not."""
        while True:
            await asyncio.sleep(TOKEN_CHECK_S)
            if not token_matches(self.services.tile_token(self.wall.id), self.token):
                raise CloseConnection(CLOSE_POLICY, "the tile token was rotated")

    async def write_loop(self, subscription: Subscription) -> None:
        """Frames are written as they are published (``Subscription.write_through``);
        this loop writes those that queued while the socket pushed back, and ends the
        connection when a write failed or the socket fell too far behind."""
        subscription.write_through(self.send)
        try:
            while True:
                await self.send(await subscription.next())
        except SubscriberTooSlow:
            raise CloseConnection(CLOSE_TRY_AGAIN, "too slow: reconnect for a snapshot") from None
        finally:
            subscription.write_through(None)

    async def receive(self) -> Hello | Ping | Ready | Applied:
        """The next frame as a message; anything malformed closes this socket."""
        frame = await self.websocket.receive()
        if frame["type"] == "websocket.disconnect":
            raise WebSocketDisconnect(frame.get("code", 1000))
        text = frame.get("text")
        if text is None:
            raise CloseConnection(CLOSE_POLICY, "binary frames are not accepted")
        if len(text) > self.services.settings.max_frame_bytes:
            raise CloseConnection(CLOSE_TOO_BIG, "frame too big")
        try:
            return CLIENT_MESSAGES.validate_json(text)
        except ValidationError as error:
            raise CloseConnection(CLOSE_POLICY, f"bad frame: {error.errors()[0]['msg']}") from None

    async def send(self, text: str) -> None:
        async with self.send_lock:
            if self.websocket.application_state == WebSocketState.DISCONNECTED:
                # a write ahead of this one found the peer gone
                raise WebSocketDisconnect(1006)
            await self.websocket.send_text(text)

    async def close(self, code: int, reason: str) -> None:
        if self.websocket.application_state != WebSocketState.DISCONNECTED:
            with contextlib.suppress(RuntimeError, WebSocketDisconnect):
                await self.websocket.close(code, reason[:120])
