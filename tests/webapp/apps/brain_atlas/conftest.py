"""The shipped atlas, read once per test module (it is only read, never changed)."""

from __future__ import annotations

import pytest

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
