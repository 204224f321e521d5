"""What a running app holds: the layouts it keeps once read."""

from __future__ import annotations

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import delete

from webapp.database.models import TagLayoutRecord
from webapp.engine.wall_state import read_state
from webapp.server.services import Services


@pytest.mark.walls("demo", "kl-3x3")  # a layout is not another wall's
def test_a_layout_is_read_once_and_kept(app: FastAPI, client: TestClient) -> None:
    """Layouts never change (a new placement is a new row): the one read is kept, and
    a layout of another wall, or none, is not found."""
    services: Services = app.state.services
    _, state = read_state(services.db, "demo")
    assert state.tag_layout
    layout = services.layout("demo", state.tag_layout)
    assert layout is not None and layout.id == state.tag_layout and layout.placed
    with services.db.session() as session:
        session.execute(delete(TagLayoutRecord))
    assert services.layout("demo", state.tag_layout) is layout, "kept, not read again"
    assert services.layout("kl-3x3", state.tag_layout) is None
    assert services.layout("demo", None) is None and services.layout("demo", 0) is None
