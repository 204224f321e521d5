"""The shipped atlas, read once per test module (it is only read, never changed); the
brain on the demo wall (``on_wall``)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.webapp.apps.brain_atlas.walls import show_brain
from webapp.apps.brain_atlas.content import Region, load_content
from webapp.apps.brain_atlas.pins import AtlasVolumes
from webapp.apps.brain_atlas.views import ViewPreset, load_views


@pytest.fixture(scope="module")
def volumes() -> AtlasVolumes:
    return AtlasVolumes.load()


@pytest.fixture(scope="module")
def regions() -> list[Region]:
    return load_content().regions


@pytest.fixture(scope="module")
def presets() -> list[ViewPreset]:
    return load_views()


@pytest.fixture
def on_wall(client: TestClient) -> TestClient:
    show_brain(client)
    return client
