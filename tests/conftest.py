"""Fixtures: every test builds its own settings, database and app (no shared state).

With TAGWALL_TEST_DATABASE_URL set (a PostgreSQL URL) each test gets a fresh
PostgreSQL database created from it; otherwise a SQLite file in its tmp_path.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

from webapp.app import create_app
from webapp.db import Database
from webapp.migrate import upgrade
from webapp.settings import CONTENT_DIR, Settings
from webapp.tags import TagSpec

TEST_SECRET = "test-secret-key-not-for-production"
POSTGRES_URL = os.environ.get("TAGWALL_TEST_DATABASE_URL", "")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "postgres: needs PostgreSQL (runs whenever TAGWALL_TEST_DATABASE_URL is set)"
    )


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    if POSTGRES_URL:
        return
    skip = pytest.mark.skip(reason="set TAGWALL_TEST_DATABASE_URL to run PostgreSQL tests")
    for item in items:
        if "postgres" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def database_url(tmp_path: Path) -> Iterator[str]:
    if not POSTGRES_URL:
        yield f"sqlite:///{tmp_path / 'tagwall.db'}"
        return
    base = make_url(POSTGRES_URL)
    name = f"tagwall_test_{uuid.uuid4().hex[:12]}"
    admin = create_engine(base, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'CREATE DATABASE "{name}"'))
    try:
        yield base.set(database=name).render_as_string(hide_password=False)
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        admin.dispose()


@pytest.fixture
def db(database_url: str) -> Iterator[Database]:
    """A migrated database of its own, for tests below the HTTP layer."""
    upgrade(database_url)
    database = Database(database_url)
    yield database
    database.dispose()


def tag_spec(**fields: object) -> TagSpec:
    """An anchored tag of a made-up quiz app, with ``fields`` changed."""
    base: dict[str, object] = {"app": "quiz", "action": "ask", "anchor": (300.0, 300.0)}
    return TagSpec.model_validate({**base, **fields})


@pytest.fixture
def settings(tmp_path: Path, database_url: str) -> Settings:
    return Settings(
        var_dir=tmp_path / "var",
        database_url=database_url,
        secret_key=TEST_SECRET,
        public_base_url="http://192.168.1.20:8000",
        wall_configs=[CONTENT_DIR / "walls"],
        apply_lead_ms=50,
        swap_timeout_ms=500,
    )


@pytest.fixture
def app(settings: Settings) -> FastAPI:
    upgrade(settings.resolved_database_url)
    return create_app(settings)


@pytest.fixture
def client(app: FastAPI) -> Iterator[TestClient]:
    with TestClient(app) as test_client:
        yield test_client


def operator_headers(client: TestClient) -> dict[str, str]:
    """The operator's bearer token for ``client``'s app."""
    token = client.app.state.services.operator_token  # type: ignore[attr-defined]
    return {"Authorization": f"Bearer {token}"}
