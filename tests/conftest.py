"""Fixtures: every test builds its own settings, database and app (no shared state).

With TAGWALL_TEST_DATABASE_URL set (a PostgreSQL URL) each test gets a fresh
PostgreSQL database created from it; otherwise a SQLite file in its tmp_path. Tests of
what several processes share use Redis: TAGWALL_TEST_REDIS_URL, else a private
redis-server, with a key prefix of their own.

`make test` runs them in a worker per core (pytest-xdist): servers take ports from
their worker's block (``server_port``), and tests marked ``alone`` run with nothing
beside them. Apps open the demo wall only, unless a test's ``walls`` marker names
others. What is costly and only read is made once per worker: the migrated SQLite
file each test's database starts as (``migrate``), the brain atlas's volume store, and
the shipped atlas's volumes and the pictures of them per view (``_ShippedAtlas``).
"""

from __future__ import annotations

import atexit
import fcntl
import functools
import itertools
import os
import re
import shutil
import socket
import subprocess
import tempfile
import threading
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import hypothesis
import numpy as np
import pytest
from fastapi import FastAPI
from fastapi.routing import APIRoute, APIWebSocketRoute
from fastapi.testclient import TestClient
from sqlalchemy.engine import make_url

from tests.cable import Cable
from tests.oidc.provider import OpenIDProvider, running_provider
from webapp.apps.brain_atlas import app as brain_app
from webapp.apps.brain_atlas import pins
from webapp.apps.brain_atlas.content import ATLAS_DIR, Region
from webapp.apps.brain_atlas.pins import TEMPLATE_FILE, VOLUME, AtlasVolumes, Orientation, PlanePin
from webapp.cli.testing import fresh_database, wait_until
from webapp.core.settings import CONTENT_DIR, Settings
from webapp.database.connection import Database
from webapp.database.migrate import upgrade
from webapp.people.accounts import add_account
from webapp.server.app import create_app
from webapp.server.services import Services
from webapp.tags.registry import TagSpec, wall_tags
from webapp.volume.build import Source, build_store, open_source
from webapp.volume.store import VolumeMeta

TEST_SECRET = "test-secret-key-not-for-production"
POSTGRES_URL = os.environ.get("TAGWALL_TEST_DATABASE_URL", "")
REDIS_URL = os.environ.get("TAGWALL_TEST_REDIS_URL", "")


def pytest_configure(config: pytest.Config) -> None:
    # Property tests prove rules, not speed: no per-example deadline (a loaded two-core
    # machine runs an example several times slower), and in CI the same examples each
    # run, so a failure there is reproducible rather than a roll of the dice.
    hypothesis.settings.register_profile("dev", deadline=None)
    hypothesis.settings.register_profile("ci", deadline=None, derandomize=True)
    hypothesis.settings.load_profile("ci" if os.environ.get("CI") else "dev")
    config.addinivalue_line(
        "markers", "postgres: needs PostgreSQL (runs whenever TAGWALL_TEST_DATABASE_URL is set)"
    )
    config.addinivalue_line(
        "markers", "browser: drives Debian Chromium against a server process (-m 'not browser')"
    )
    config.addinivalue_line(
        "markers",
        "alone: runs with no other test beside it (under xdist: a lock over the workers)",
    )
    config.addinivalue_line(
        "markers",
        "walls(*names): the shipped walls the test's app opens (default: demo only)",
    )
    config.addinivalue_line(
        "markers",
        "persistence: a browser test of what the database keeps across restarts and crashes "
        "(CI's PostgreSQL pass runs these and every test that is not a browser test)",
    )


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    browser_tests = Path(__file__).parent / "browser"
    skip = pytest.mark.skip(reason="set TAGWALL_TEST_DATABASE_URL to run PostgreSQL tests")
    for item in items:
        if item.path.is_relative_to(browser_tests):
            item.add_marker(pytest.mark.browser)
        if "postgres" in item.keywords and not POSTGRES_URL:
            item.add_marker(skip)


# --- running in parallel (pytest-xdist: `make test` runs a worker per core) ---------------

WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")  # gw0, gw1, ... ("" without xdist)
# Each worker takes server ports from a block of its own, below the kernel's ephemeral
# range (32768-60999 on Linux), so a port a test's server gave up (to restart on it, say)
# is never handed to another worker's server, nor to a client socket, meanwhile. A run's
# workers take consecutive blocks from one chosen by the run's id, so two runs on one
# machine (two worktrees) seldom share blocks; a port in use is passed over anyway.
PORT_BLOCK = 200
_BLOCKS = (32_768 - 20_000) // PORT_BLOCK
_RUN = int(os.environ.get("PYTEST_XDIST_TESTRUNUID", "0")[:8] or "0", 16)
_FIRST_PORT = 20_000 + PORT_BLOCK * ((_RUN + int(WORKER.removeprefix("gw") or 0)) % _BLOCKS)
_next_ports = itertools.cycle(range(_FIRST_PORT, _FIRST_PORT + PORT_BLOCK))


def server_port() -> int:
    """A port for a test's server process: the next free one of this worker's block."""
    for _ in range(PORT_BLOCK):
        port = next(_next_ports)
        with socket.socket() as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn binds
            try:
                probe.bind(("0.0.0.0", port))
            except OSError:
                continue
        return port
    raise RuntimeError(f"no free port in {_FIRST_PORT}-{_FIRST_PORT + PORT_BLOCK - 1}")


@pytest.fixture(autouse=True)
def _share_the_machine(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[None]:
    """Tests marked ``alone`` (a kill -9 with requests in flight, tiles that must show a
    change in step, several server processes at once) run with no other test beside
    them: a readers-writer lock over the run's workers, shared by every other test.
    A turnstile in front keeps a waiting ``alone`` test from being starved."""
    if not WORKER:
        yield
        return
    run_dir = tmp_path_factory.getbasetemp().parent  # shared by this run's workers
    alone = request.node.get_closest_marker("alone") is not None
    with (
        (run_dir / "turnstile.lock").open("a") as turnstile,
        (run_dir / "machine.lock").open("a") as machine,
    ):
        fcntl.flock(turnstile, fcntl.LOCK_EX)
        try:
            fcntl.flock(machine, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        finally:
            fcntl.flock(turnstile, fcntl.LOCK_UN)
        try:
            yield
        finally:
            fcntl.flock(machine, fcntl.LOCK_UN)


# --- the brain atlas's volume, built once per test process ----------------------------

_MNI152: list[tuple[Path, VolumeMeta]] = []
_MNI152_GUARD = threading.Lock()


def _mni152_once(source: Source, out: Path, **options: Any) -> VolumeMeta:
    """``build_store`` as the brain atlas calls it on a wall's first show: the MNI
    template's store (seconds of CPU) is built for real once per test process and then
    hard-linked into each test's volume folder (stores are only ever read, and rebuilt
    by replacing the folder), as a copy would be (from a content folder too, when its
    template links to the shipped one). Any other build is built."""
    shipped = (ATLAS_DIR / TEMPLATE_FILE).resolve()
    if source.path.resolve() != shipped or options != {"name": VOLUME}:
        return build_store(source, out, **options)
    with _MNI152_GUARD:
        if not _MNI152:
            folder = Path(tempfile.mkdtemp(prefix="tagwall-mni152-"))
            atexit.register(shutil.rmtree, folder, ignore_errors=True)
            _MNI152.append((folder / VOLUME, build_store(source, folder / VOLUME, **options)))
        built, meta = _MNI152[0]
        out.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
        shutil.copytree(built, staging, copy_function=os.link, dirs_exist_ok=True)
        if out.exists():
            shutil.rmtree(out)
        staging.rename(out)
        return meta


class _ShippedAtlas:
    """The shipped atlas as every test that shows the brain reads it, worked out once
    per test process: its volumes (a second to read) and, per view, the regions the
    picture shows and their pins (rays cast through the volume: a tenth of a second or
    more per view, for every brain test). Both are only ever read. Another atlas folder
    or volume is read and cast for real."""

    def __init__(self) -> None:
        self._load = AtlasVolumes.load  # the real ones, saved before they are patched
        self._cast = pins.visible_regions
        self._volumes: AtlasVolumes | None = None
        self._pictures: dict[object, dict[str, PlanePin]] = {}
        self._guard = threading.Lock()

    def load(self, directory: Path = ATLAS_DIR, meta: VolumeMeta | None = None) -> AtlasVolumes:
        if meta is not None or directory.resolve() != ATLAS_DIR.resolve():
            return self._load(directory, meta)
        with self._guard:
            if self._volumes is None:
                self._volumes = self._load(directory)
            return self._volumes

    def visible_regions(
        self, volumes: AtlasVolumes, regions: Sequence[Region], orientation: Orientation
    ) -> dict[str, PlanePin]:
        if volumes is not self._volumes:
            return self._cast(volumes, regions, orientation)
        key = (orientation, tuple((r.id, tuple(r.labels)) for r in regions))
        with self._guard:
            known = self._pictures.get(key)
        if known is None:
            known = self._cast(volumes, regions, orientation)
            with self._guard:
                self._pictures[key] = known
        return dict(known)


_SHIPPED_ATLAS = _ShippedAtlas()


@pytest.fixture(autouse=True)
def _shipped_content_read_once(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(brain_app, "build_store", _mni152_once)
    monkeypatch.setattr(AtlasVolumes, "load", _SHIPPED_ATLAS.load)
    monkeypatch.setattr(pins, "visible_regions", _SHIPPED_ATLAS.visible_regions)


@pytest.fixture(scope="session")
def redis_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """The Redis URL tests use: ``TAGWALL_TEST_REDIS_URL`` (CI: the machine's Redis), else a
    private ``redis-server`` (Debian's redis-server package, which ``make test`` installs)
    on a free port, without persistence, for the whole session."""
    if REDIS_URL:
        yield REDIS_URL
        return
    executable = shutil.which("redis-server")
    if executable is None:
        pytest.fail("redis-server is not installed: run `make test` (it installs it as root)")
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    folder = tmp_path_factory.mktemp("redis")
    process = subprocess.Popen(
        [
            executable,
            "--port",
            str(port),
            "--bind",
            "127.0.0.1",
            "--save",
            "",
            "--appendonly",
            "no",
        ],
        cwd=folder,
        stdout=subprocess.DEVNULL,
    )
    try:
        url = f"redis://127.0.0.1:{port}/0"
        wait_until(lambda: _answers(port), what="redis-server to start", timeout=30)
        yield url
    finally:
        process.terminate()
        process.wait(timeout=10)


def _answers(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=1) as connection:
            connection.sendall(b"PING\r\n")
            return connection.recv(16).startswith(b"+PONG")
    except OSError:
        return False


@pytest.fixture(scope="session")
def openid_provider(tmp_path_factory: pytest.TempPathFactory) -> Iterator[OpenIDProvider]:
    """The test OpenID Provider (tests/oidc/: oidc-provider from npm), started once per
    test process; each test registers a client of its own."""
    with running_provider(tmp_path_factory.mktemp("oidc"), server_port()) as provider:
        yield provider


@pytest.fixture
def redis_prefix() -> str:
    """Each test's own key prefix on the shared Redis, so tests never see each other's keys."""
    return f"tagwall-test:{uuid.uuid4().hex[:12]}"


@pytest.fixture
def redis_cable(redis_server: str) -> Iterator[Cable]:
    """A cable to the test Redis: pass ``redis_cable.url`` to what should lose Redis."""
    cable = Cable(redis_server)
    yield cable
    cable.close()


@pytest.fixture
def database_url(tmp_path: Path) -> Iterator[str]:
    with fresh_database(POSTGRES_URL, tmp_path) as url:
        yield url


@functools.cache
def _migrated_sqlite() -> Path:
    """A SQLite database migrated to the newest revision, once per test process."""
    folder = Path(tempfile.mkdtemp(prefix="tagwall-migrated-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    path = folder / "tagwall.db"
    upgrade(f"sqlite:///{path}")
    return path


def migrate(url: str) -> None:
    """Bring a test's database at ``url`` to the newest revision, as ``upgrade`` does: a
    SQLite file not made yet is a copy of one migrated once per process (alembic costs
    a tenth of a second a test); anything else (PostgreSQL, a file that exists) is
    upgraded by alembic. tests/test_migrations.py runs the migrations themselves."""
    database = make_url(url)
    path = Path(database.database or "")
    if database.get_backend_name() == "sqlite" and database.database and not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(_migrated_sqlite(), path)
        return
    upgrade(url)


@pytest.fixture
def db(database_url: str) -> Iterator[Database]:
    """A migrated database of its own, for tests below the HTTP layer."""
    migrate(database_url)
    database = Database(database_url)
    yield database
    database.dispose()


def tag_spec(**fields: object) -> TagSpec:
    """An anchored tag of a made-up quiz app, with ``fields`` changed."""
    base: dict[str, object] = {"app": "quiz", "action": "ask", "anchor": (300.0, 300.0)}
    return TagSpec.model_validate({**base, **fields})


def wall_files(*names: str) -> list[Path]:
    """The shipped configs of the walls ``names``."""
    return [CONTENT_DIR / "walls" / f"{name}.toml" for name in names]


def walls_of(request: pytest.FixtureRequest) -> tuple[str, ...]:
    """The shipped walls a test's app opens: ``demo``, or those of its ``walls`` marker."""
    marker = request.node.get_closest_marker("walls")
    return tuple(marker.args) if marker else ("demo",)


@pytest.fixture
def settings(tmp_path: Path, database_url: str, request: pytest.FixtureRequest) -> Settings:
    # Opening a wall places every one of its codes; the big walls (hiperwall's fifty
    # displays) cost a second each, so only tests that use them (marked) open them.
    return Settings(
        var_dir=tmp_path / "var",
        database_url=database_url,
        secret_key=TEST_SECRET,
        public_base_url="http://192.168.1.20:8000",
        wall_configs=wall_files(*walls_of(request)),
        apply_lead_ms=50,
        swap_timeout_ms=500,
        # Tests act faster than people: a phone counts as settled at once. The abuse
        # limits' own tests (tests/webapp/server/routes/test_limits.py) use the default.
        visitor_settle_s=0,
    )


@pytest.fixture
def app(settings: Settings) -> FastAPI:
    migrate(settings.resolved_database_url)
    return create_app(settings)


@pytest.fixture
def client(app: FastAPI) -> Iterator[TestClient]:
    with TestClient(app) as test_client:
        yield test_client


def operator_headers(client: TestClient) -> dict[str, str]:
    """The operator's bearer token for ``client``'s app."""
    token = client.app.state.services.operator_token  # type: ignore[attr-defined]
    return {"Authorization": f"Bearer {token}"}


TEST_PASSWORD = "correct-horse-battery"
_CSRF = re.compile(r'name="csrf" value="([^"]+)"')


def services_of(client: TestClient) -> Services:
    services: Services = client.app.state.services  # type: ignore[attr-defined]
    return services


def csrf_of(client: TestClient, page: str = "/me") -> str:
    """The CSRF token of ``client``'s session, read off a page as a browser would."""
    match = _CSRF.search(client.get(page).text)
    assert match, f"no csrf field on {page}"
    return match.group(1)


def sign_in(client: TestClient, role: str, username: str | None = None) -> str:
    """Make an account of ``role`` and sign ``client`` in through the login form."""
    name = username or f"{role}-one"
    add_account(services_of(client).db, name, role, TEST_PASSWORD, actor="test")
    response = client.post(
        "/login",
        data={"username": name, "password": TEST_PASSWORD, "csrf": csrf_of(client, "/login")},
        follow_redirects=False,
    )
    assert response.status_code == 303, response.text
    return name


def register_student(client: TestClient, wall: str = "demo") -> None:
    """Scan the wall's student registration code."""
    code = next(
        t.code for t in wall_tags(services_of(client).db, wall) if t.name == "register-student"
    )
    assert client.get(f"/t/{code}").status_code == 200


def blob_volume(shape: tuple[int, int, int] = (40, 36, 28), seed: int = 7) -> np.ndarray:
    """A smooth uint8 volume: a few Gaussian blobs on an empty background."""
    rng = np.random.default_rng(seed)
    grid = np.indices(shape).astype(np.float64)
    volume = np.zeros(shape)
    for _ in range(5):
        centre = rng.uniform(0.25, 0.75, 3) * np.array(shape)
        width = rng.uniform(0.08, 0.2) * min(shape)
        squared = sum((grid[a] - centre[a]) ** 2 for a in range(3))
        volume += rng.uniform(0.5, 1.0) * np.exp(-squared / (2 * width**2))
    volume = volume / volume.max() * 255
    volume[volume < 12] = 0
    return volume.astype(np.uint8)


def build_test_volume(settings: Settings, name: str = "blobs") -> str:
    """A small volume store in the settings' volume directory; its name."""
    path = settings.resolved_volume_dir / name
    if not (path / "volume.json").exists():
        source = settings.var_dir / f"{name}.npy"
        source.parent.mkdir(parents=True, exist_ok=True)
        np.save(source, blob_volume())
        build_store(open_source(source), path, name=name, brick=8)
    return name


def routes_of(app: FastAPI) -> set[tuple[str, str]]:
    """Every (method, path) the app answers, websockets as ``WS``: the routes of
    included routers too, however deeply nested (an app's router includes its rooms')."""
    found = set()
    pending: list[Any] = list(app.routes)
    while pending:
        route = pending.pop()
        if (router := getattr(route, "original_router", None)) is not None:
            pending.extend(router.routes)
        elif isinstance(route, APIRoute):
            found |= {(method, route.path) for method in route.methods}
        elif isinstance(route, APIWebSocketRoute):
            found.add(("WS", route.path))
    return found
