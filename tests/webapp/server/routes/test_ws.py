"""The tile protocol over real websockets (Starlette's test client)."""

from __future__ import annotations

import json
from types import SimpleNamespace
from typing import Any, cast

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect, WebSocketState

from tests.conftest import TEST_SECRET, migrate
from tests.conftest import operator_headers as operator
from webapp.core.settings import Settings
from webapp.engine.bus.redis import RedisBus
from webapp.engine.protocol import CLOSE_POLICY, CLOSE_TOO_BIG, CLOSE_TRY_AGAIN, CLOSE_UNKNOWN
from webapp.people.security import tile_token
from webapp.server.app import create_app
from webapp.server.routes.ws import Connection

TOKEN = tile_token(TEST_SECRET, "demo")
TILE = f"/ws/wall/demo/tile/r1c1?token={TOKEN}"


def version_now(client: TestClient) -> int:
    """The wall's version (the app's start already put the wall's codes up)."""
    status = client.get("/api/walls/demo/status", headers=operator(client))
    return int(status.json()["version"])


def change(client: TestClient, **patch: object) -> int:
    response = client.post("/api/walls/demo/state", json=patch, headers=operator(client))
    assert response.status_code == 200, response.text
    return int(response.json()["version"])


def test_hello_without_version_gets_a_snapshot_with_viewport(client: TestClient) -> None:
    version = change(client, layers={"quiz": True})
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello", "last_version": None})
        snapshot = ws.receive_json()
    assert snapshot["type"] == "snapshot"
    assert snapshot["version"] == version and snapshot["state"]["layers"] == {"quiz": True}
    assert snapshot["viewport"]["display_id"] == "r1c1"
    assert len(snapshot["viewport"]["to_pixels"]) == 6


def test_live_events_follow_in_order(client: TestClient) -> None:
    start = version_now(client)
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        assert ws.receive_json()["version"] == start
        for index in range(3):
            change(client, layers={f"m{index}": True})
        events = [ws.receive_json() for _ in range(3)]
    assert [e["type"] for e in events] == ["event"] * 3
    assert [e["version"] for e in events] == [start + 1, start + 2, start + 3]
    assert events[2]["changes"] == {"layers": {"m0": True, "m1": True, "m2": True}}


def test_reconnect_replays_only_missed_events(client: TestClient) -> None:
    start = version_now(client)
    for index in range(4):
        change(client, layers={f"m{index}": True})
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello", "last_version": start + 2})
        replay = [ws.receive_json() for _ in range(2)]
    assert [(e["type"], e["version"], e["apply_at"]) for e in replay] == [
        ("event", start + 3, 0),
        ("event", start + 4, 0),
    ]


def test_reconnect_after_a_missed_heavy_change_gets_a_snapshot(client: TestClient) -> None:
    """A heavy change (here the app, with its codes' layout) needs loading before it is
    shown, which a tile does for a snapshot: a replayed event would show the new state
    without its codes (seen after a restart that switched the wall's app)."""
    start = version_now(client)
    change(client, layers={"seen": True})
    change(client, app="census")
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello", "last_version": start})
        message = ws.receive_json()
    assert message["type"] == "snapshot" and message["version"] == start + 2
    assert message["state"]["app"] == "census"


def test_reconnect_beyond_history_gets_snapshot(client: TestClient) -> None:
    client.app.state.services.hub.keep_events = 2  # type: ignore[attr-defined]
    start = version_now(client)
    for index in range(5):
        change(client, layers={f"m{index}": True})
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello", "last_version": start + 1})
        message = ws.receive_json()
    assert message["type"] == "snapshot" and message["version"] == start + 5


def test_tile_from_the_future_gets_snapshot(client: TestClient) -> None:
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello", "last_version": 99})
        message = ws.receive_json()
    assert message["type"] == "snapshot" and message["version"] == version_now(client)


def test_ping_gets_pong_with_server_times(client: TestClient) -> None:
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        ws.receive_json()
        ws.send_json({"type": "ping", "t0": 1234.5})
        pong = ws.receive_json()
    assert pong["type"] == "pong" and pong["t0"] == 1234.5
    assert pong["t1"] <= pong["t2"]


def test_heavy_change_goes_through_prepare_ready_swap(client: TestClient) -> None:
    version = version_now(client) + 1
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        ws.receive_json()
        change(client, view={"center": [0.4, 0.5], "zoom": 2})
        prepare = ws.receive_json()
        assert prepare["type"] == "prepare" and prepare["version"] == version
        ws.send_json({"type": "ready", "version": version})
        swap = ws.receive_json()
        ws.send_json({"type": "applied", "version": version, "server_time": swap["apply_at"]})
        ws.send_json({"type": "ping", "t0": 0})
        ws.receive_json()
    assert swap == {"type": "swap", "version": version, "apply_at": swap["apply_at"]}
    status = client.get("/api/walls/demo/status", headers=operator(client)).json()
    tile = next(t for t in status["tiles"] if t["tile_id"] == "r1c1")
    assert tile["version"] == version and not tile["connected"]


def test_dashboard_status_shows_connected_tile(client: TestClient) -> None:
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        ws.receive_json()
        status = client.get("/api/walls/demo/status", headers=operator(client)).json()
    tiles = {t["tile_id"]: t for t in status["tiles"]}
    assert tiles["r1c1"]["connected"] and not tiles["r1c2"]["connected"]
    assert len(tiles) == 6


def closed_with(client: TestClient, url: str, *frames: object) -> int:
    """Send frames and return the close code the server answered with."""
    with client.websocket_connect(url) as ws:
        for frame in frames:
            if isinstance(frame, bytes):
                ws.send_bytes(frame)
            elif isinstance(frame, str):
                ws.send_text(frame)
            else:
                ws.send_json(frame)
        with pytest.raises(WebSocketDisconnect) as closed:
            while True:
                ws.receive_json()
    return closed.value.code


def test_bad_token_is_refused(client: TestClient) -> None:
    assert closed_with(client, "/ws/wall/demo/tile/r1c1?token=nope") == CLOSE_POLICY
    assert closed_with(client, "/ws/wall/demo/tile/r1c1") == CLOSE_POLICY
    other_wall = tile_token(TEST_SECRET, "kl-3x3")
    assert closed_with(client, f"/ws/wall/demo/tile/r1c1?token={other_wall}") == CLOSE_POLICY


def test_unknown_wall_or_tile_is_refused(client: TestClient) -> None:
    assert closed_with(client, f"/ws/wall/nowall/tile/r1c1?token={TOKEN}") == CLOSE_UNKNOWN
    assert closed_with(client, f"/ws/wall/demo/tile/r9c9?token={TOKEN}") == CLOSE_UNKNOWN
    assert closed_with(client, "/ws/wall/nowall/view") == CLOSE_UNKNOWN


@pytest.mark.parametrize(
    "frames",
    [
        ("not json",),
        ({"type": "shout"},),
        ({"type": "hello", "last_version": -1},),
        ({"type": "hello", "extra": 1},),
        ({"type": "ping", "t0": 0},),  # first frame must be hello
        (b"\x00\x01",),
        ({"type": "hello"}, {"type": "ready", "version": "soon"}),
        ({"type": "hello"}, "[1, 2, 3]"),
    ],
)
def test_bad_frames_close_with_policy_code(client: TestClient, frames: tuple[object, ...]) -> None:
    assert closed_with(client, TILE, *frames) == CLOSE_POLICY


def test_oversized_frame_closes_with_too_big(client: TestClient) -> None:
    huge = json.dumps({"type": "ping", "t0": 1, "pad": "x" * 10_000})
    assert closed_with(client, TILE, {"type": "hello"}, huge) == CLOSE_TOO_BIG


def test_viewer_receives_but_cannot_report(client: TestClient) -> None:
    with client.websocket_connect("/ws/wall/demo/view") as ws:
        ws.send_json({"type": "hello"})
        snapshot = ws.receive_json()
        assert snapshot["type"] == "snapshot" and snapshot["viewport"] is None
        change(client, layers={"quiz": True})
        assert ws.receive_json()["changes"] == {"layers": {"quiz": True}}
    frames = ({"type": "hello"}, {"type": "ready", "version": 1})
    assert closed_with(client, "/ws/wall/demo/view", *frames) == CLOSE_POLICY


def test_bad_client_does_not_disturb_other_tiles(client: TestClient) -> None:
    with client.websocket_connect(TILE) as good:
        good.send_json({"type": "hello"})
        good.receive_json()
        assert closed_with(client, TILE, "garbage") == CLOSE_POLICY
        change(client, layers={"after": True})
        assert good.receive_json()["changes"] == {"layers": {"after": True}}


def test_slow_tile_is_dropped_and_resyncs(client: TestClient) -> None:
    hub = client.app.state.services.hub  # type: ignore[attr-defined]
    hub.bus.queue_size = 4

    async def burst() -> None:  # faster than any socket can drain: no await yields
        for version in range(1, 40):
            await hub.bus.publish("demo", json.dumps({"type": "event", "version": version}))

    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        ws.receive_json()
        client.portal.call(burst)  # type: ignore[union-attr]
        with pytest.raises(WebSocketDisconnect) as closed:
            while True:
                ws.receive_json()
    assert closed.value.code == CLOSE_TRY_AGAIN
    with client.websocket_connect(TILE) as ws:
        ws.send_json({"type": "hello"})
        assert ws.receive_json()["type"] == "snapshot"


async def test_a_frame_for_a_peer_already_gone_is_a_disconnect() -> None:
    """A frame written on the publisher's turn may find the peer gone while the
    connection's own loop waits to send another: that one ends the connection as a
    disconnect, which it handles quietly, not as Starlette's error for a closed socket."""
    websocket = SimpleNamespace(application_state=WebSocketState.DISCONNECTED)
    connection = Connection(
        cast(Any, websocket), cast(Any, SimpleNamespace(hub=None)), cast(Any, None), None
    )
    with pytest.raises(WebSocketDisconnect):
        await connection.send("frame")


# --- several server processes on one Redis (TAGWALL_BUS=redis) -----------------------


@pytest.fixture
def redis_settings(settings: Settings, redis_server: str, redis_prefix: str) -> Settings:
    """Settings of a server process on the test's Redis bus."""
    update = {"bus": "redis", "redis_url": redis_server, "redis_prefix": redis_prefix}
    return settings.model_copy(update=update)


def test_a_tile_on_the_redis_bus_receives_changes(redis_settings: Settings) -> None:
    migrate(redis_settings.resolved_database_url)
    with TestClient(create_app(redis_settings)) as client:
        assert isinstance(client.app.state.services.hub.bus, RedisBus)  # type: ignore[attr-defined]
        start = version_now(client)
        with client.websocket_connect(TILE) as ws:
            ws.send_json({"type": "hello"})
            assert ws.receive_json()["version"] == start  # the snapshot: subscribed
            version = change(client, layers={"quiz": True})
            event = ws.receive_json()
    assert event["type"] == "event" and event["version"] == version == start + 1
    assert event["changes"] == {"layers": {"quiz": True}}


def test_two_server_processes_serve_one_wall(redis_settings: Settings) -> None:
    """A change made through one process reaches the tiles of the other, in order."""
    migrate(redis_settings.resolved_database_url)
    with (
        TestClient(create_app(redis_settings)) as one,
        TestClient(create_app(redis_settings)) as two,
        two.websocket_connect(TILE) as ws,
    ):
        start = version_now(two)
        ws.send_json({"type": "hello"})
        assert ws.receive_json()["version"] == start  # the snapshot: subscribed
        versions = [
            change(one if index % 2 else two, layers={"shown": index % 2 == 0})
            for index in range(4)
        ]
        events = [ws.receive_json() for _ in range(4)]
    assert versions == [start + 1, start + 2, start + 3, start + 4]
    assert [e["version"] for e in events] == versions
    assert [e["changes"]["layers"]["shown"] for e in events] == [True, False, True, False]
