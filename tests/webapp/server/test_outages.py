"""The database going away while the server runs: pages and the API answer 503 with
Retry-After (never a 500 or a traceback), and everything works again when it is back."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import TimeoutError as PoolTimeout

from tests.cable import Cable
from tests.conftest import (
    POSTGRES_URL,
    TEST_SECRET,
    csrf_of,
    migrate,
    operator_headers,
    register_student,
    services_of,
)
from webapp.core.settings import Settings
from webapp.people.security import tile_token
from webapp.server.app import create_app
from webapp.tags.registry import wall_tags


def outage(url: str, tmp_path: Path) -> tuple[Callable[[], None], Callable[[], None]]:
    """How to take the database at ``url`` away and bring it back."""
    if url.startswith("sqlite"):
        folder = Path(make_url(url).database or "").parent
        away = tmp_path / "away"
        return (lambda: shutil.move(folder, away)), (lambda: shutil.move(away, folder))
    name = make_url(url).database
    admin = create_engine(make_url(POSTGRES_URL), isolation_level="AUTOCOMMIT")

    def run(*statements: str) -> None:
        with admin.connect() as connection:
            for statement in statements:
                connection.execute(text(statement))

    down = (
        f'ALTER DATABASE "{name}" ALLOW_CONNECTIONS false',
        f"SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = '{name}'",
    )
    return (lambda: run(*down)), (lambda: run(f'ALTER DATABASE "{name}" ALLOW_CONNECTIONS true'))


def test_a_database_outage_is_503_not_500(
    settings: Settings, database_url: str, tmp_path: Path
) -> None:
    if database_url.startswith("sqlite"):  # in a folder of its own, so it can go away
        database_url = f"sqlite:///{tmp_path / 'db' / 'tagwall.db'}"
    settings = settings.model_copy(update={"database_url": database_url})
    migrate(database_url)
    app = create_app(settings)
    take_down, bring_back = outage(database_url, tmp_path)
    with TestClient(app, raise_server_exceptions=False) as phone:
        register_student(phone)
        operator = operator_headers(phone)
        take_down()
        app.state.services.db.engine.dispose()  # connections of the old database go too
        try:
            page = phone.get("/me")
            api = phone.get("/api/walls/demo/status", headers=operator)
            health = phone.get("/healthz")
        finally:
            bring_back()
        assert (page.status_code, api.status_code, health.status_code) == (503, 503, 503)
        assert "The database is not answering" in page.text and "Traceback" not in page.text
        assert api.json() == {"detail": "The database is not answering. Try again in a moment."}
        assert page.headers["retry-after"] == api.headers["retry-after"] == "5"
        assert phone.get("/me").status_code == 200, "and back when the database is"
        assert phone.get("/api/walls/demo/status", headers=operator).status_code == 200


def exhaust_pool(engine: Engine, connections: ExitStack) -> None:
    """Check out every connection ``engine``'s pool has, into ``connections``."""
    with pytest.raises(PoolTimeout):
        while True:
            connections.enter_context(engine.connect())


@pytest.mark.walls("hiperwall")
def test_a_server_out_of_connections_is_503_not_500(
    settings: Settings, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A process so loaded that a change waits out the pool's timeout for a connection
    (every one checked out by other requests) answers 503 with Retry-After, as for a
    database that does not answer, not a 500 with a traceback; the change was not
    made, and goes through once connections are free again."""
    migrate(settings.resolved_database_url)
    app = create_app(settings)
    with TestClient(app, raise_server_exceptions=False) as client:
        operator = operator_headers(client)
        start = client.get("/api/walls/hiperwall/status", headers=operator).json()["version"]
        engine = services_of(client).db.engine
        monkeypatch.setattr(engine.pool, "_timeout", 0.2)  # not the 30 s a server waits
        with ExitStack() as connections:
            exhaust_pool(engine, connections)
            change = {"layers": {"grid": False}}
            answer = client.post("/api/walls/hiperwall/state", json=change, headers=operator)
        assert answer.status_code == 503 and answer.headers["retry-after"] == "5"
        assert answer.json() == {"detail": "The database is not answering. Try again in a moment."}
        status = client.get("/api/walls/hiperwall/status", headers=operator).json()
        assert status["version"] == start, "the change waited and was not made"
        again = client.post("/api/walls/hiperwall/state", json=change, headers=operator)
        assert again.status_code == 200 and again.json()["version"] == start + 1


def test_a_redis_outage_is_503_not_500(
    settings: Settings, redis_cable: Cable, redis_prefix: str
) -> None:
    """With several server processes the limits count in Redis: while it does not
    answer, what a limit guards (scans, sign-ins) gets 503 with Retry-After, never a
    500, and the rest of the site keeps working."""
    update = {"bus": "redis", "redis_url": redis_cable.url, "redis_prefix": redis_prefix}
    settings = settings.model_copy(update=update)
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings), raise_server_exceptions=False) as phone:
        code = next(
            t.code for t in wall_tags(services_of(phone).db, "demo") if t.name == "register-student"
        )
        csrf = csrf_of(phone, "/login")
        redis_cable.cut()
        try:
            scan = phone.get(f"/t/{code}")
            sign_in = phone.post("/login", data={"username": "ines", "password": "g", "csrf": csrf})
            me = phone.get("/me")
        finally:
            redis_cable.mend()
        for answer in (scan, sign_in):
            assert answer.status_code == 503
            assert answer.headers["retry-after"] == "5"
            assert "The shared store is not answering" in answer.text
            assert "Traceback" not in answer.text
        assert me.status_code == 200


def test_a_redis_outage_is_503_and_tiles_ride_it_out(
    settings: Settings, redis_cable: Cable, redis_prefix: str
) -> None:
    """With TAGWALL_BUS=redis and Redis gone, a change answers 503 with Retry-After. A
    tile connecting meanwhile gets its snapshot from the database: the process reads the
    wall's stream from its start (the hub follows every wall), so the reader resumes
    when Redis is back and the tile receives the next change."""
    update = {"bus": "redis", "redis_url": redis_cable.url, "redis_prefix": redis_prefix}
    settings = settings.model_copy(update=update)
    migrate(settings.resolved_database_url)
    tile = f"/ws/wall/demo/tile/r1c1?token={tile_token(TEST_SECRET, 'demo')}"
    with TestClient(create_app(settings), raise_server_exceptions=False) as client:
        operator = operator_headers(client)
        with client.websocket_connect(tile) as ws:
            redis_cable.cut()
            try:
                api = client.post(
                    "/api/walls/demo/state", json={"layers": {"x": True}}, headers=operator
                )
                ws.send_json({"type": "hello"})
                snapshot = ws.receive_json()
            finally:
                redis_cable.mend()
            assert api.status_code == 503 and api.headers["retry-after"] == "5"
            assert api.json() == {
                "detail": "The event bus is not answering. Try again in a moment."
            }
            assert snapshot["type"] == "snapshot"
            again = client.post(
                "/api/walls/demo/state", json={"layers": {"x": False}}, headers=operator
            )
            assert again.status_code == 200
            event = ws.receive_json()
            while event["type"] != "event":  # frames of changes the app made at start
                event = ws.receive_json()
            assert event["changes"] == {"layers": {"x": False}}
