"""The instructor's controls of the brain on a wall (``routes/control``): mode, view,
pin set, the status and the pins no view shows."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi.testclient import TestClient

from tests.conftest import operator_headers
from tests.webapp.apps.brain_atlas.walls import brain, control, region_of, state_of
from webapp.apps.brain_atlas.state import BrainState


def test_the_dashboard_names_the_regions_whose_pin_no_view_shows(
    on_wall: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 31: on a wall of smaller displays 6 of 23 pins had no code in any view and
    the dashboard did not say so. It asks, from the views the phones' hints name: on
    the demo wall every pin has one; with a view that places no code for pin 2, its
    region is named (to staff only: names are the answers)."""
    url = "/api/apps/brain/walls/demo/unshown"
    assert on_wall.get(url).status_code == 401
    ours = operator_headers(on_wall)
    unshown = on_wall.get(url, headers=ours).json()
    assert unshown == {"round": 1, "tag_set": "full", "pins": 23, "regions": []}
    app = brain(on_wall)
    found = app._pin_views

    def without_pin_two(*args: Any) -> dict[int, list[str]]:
        return {n: views for n, views in found(*args).items() if n != 2}

    monkeypatch.setattr(app, "_pin_views", without_pin_two)
    unshown = on_wall.get(url, headers=ours).json()
    assert unshown["regions"] == [region_of(on_wall, "full", 2).name]
    on_wall.post("/api/walls/demo/state", json={"app": "pattern"}, headers=ours)
    away = on_wall.get(url, headers=ours)  # its pins stand on the brain the wall shows
    assert away.status_code == 409 and "not on" in away.json()["detail"]


def test_the_dashboard_switches_modes_presets_and_sets_and_resets_the_quiz(
    on_wall: TestClient,
) -> None:
    app = brain(on_wall)
    status = control(on_wall, mode="tutor", tag_set="k5", preset=app.views[1].id)
    assert (status["mode"], status["tag_set"]) == ("tutor", "k5")
    state = state_of(on_wall)
    assert state.view == app.views[1].view
    # tutor pages name every pin: the running round closed with the switch
    assert (status["round"]["number"], status["round"]["open"]) == (1, False)
    back = control(on_wall, mode="quiz")  # and quiz mode starts the next one
    assert (back["round"]["number"], back["round"]["open"]) == (2, True)
    assert BrainState.of(state_of(on_wall)).quiz_round == 2

    reset = on_wall.post("/api/apps/brain/walls/demo/quiz/reset", headers=operator_headers(on_wall))

    assert reset.status_code == 200 and reset.json()["round"]["number"] == 3
    bad = on_wall.post(
        "/api/apps/brain/walls/demo", json={"preset": "nowhere"}, headers=operator_headers(on_wall)
    )
    assert bad.status_code == 404
    extra = on_wall.post(
        "/api/apps/brain/walls/demo", json={"colour": "red"}, headers=operator_headers(on_wall)
    )
    assert extra.status_code == 422


def test_controls_refuse_when_the_brain_is_not_on_the_wall(client: TestClient) -> None:
    response = client.post(
        "/api/apps/brain/walls/demo", json={"mode": "tutor"}, headers=operator_headers(client)
    )
    assert response.status_code == 409
