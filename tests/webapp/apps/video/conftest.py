"""The video app's tests share their sample videos: each made once per test process."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tests.webapp.apps.video.samples import make

Samples = Callable[[str], Path]


@pytest.fixture(scope="session")
def video_sample(tmp_path_factory: pytest.TempPathFactory) -> Samples:
    """``video_sample(name)``: the sample video ``name`` (``samples.SAMPLES``), made the
    first time a test of this process asks for it."""
    folder = tmp_path_factory.mktemp("videos")
    made: dict[str, Path] = {}

    def get(name: str) -> Path:
        if name not in made:
            made[name] = make(name, folder)
        return made[name]

    return get
