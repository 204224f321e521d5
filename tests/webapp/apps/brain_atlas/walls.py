"""The brain on the demo wall as the tests drive it: the instructor's controls, the
pins the wall shows, a phone's answers."""

from __future__ import annotations

from typing import Any

from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, services_of
from webapp.apps.brain_atlas.app import BrainApp
from webapp.apps.brain_atlas.atlas import Atlas
from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.apps.brain_atlas.state import BrainState
from webapp.engine.wall_state import WallState, read_state
from webapp.tags.registry import get_layout, wall_tags


def state_of(client: TestClient) -> WallState:
    return read_state(services_of(client).db, "demo")[1]


def brain(client: TestClient) -> Atlas:
    """The brain atlas the server reads (that of its content folder)."""
    services = services_of(client)
    app = services.apps["brain"]
    assert isinstance(app, BrainApp)
    return app.atlas(services.settings)


def show_brain(client: TestClient) -> WallState:
    response = client.post(
        "/api/walls/demo/state", json={"app": "brain"}, headers=operator_headers(client)
    )
    assert response.status_code == 200, response.text
    return state_of(client)


def control(client: TestClient, **choice: Any) -> dict[str, Any]:
    response = client.post(
        "/api/apps/brain/walls/demo", json=choice, headers=operator_headers(client)
    )
    assert response.status_code == 200, response.text
    body: dict[str, Any] = response.json()
    return body


def brain_codes(client: TestClient) -> dict[str, str]:
    """Live brain tags by name -> code."""
    tags = wall_tags(services_of(client).db, "demo")
    return {t.name: t.code for t in tags if t.app == "brain" and t.active and t.name}


def placed_codes(client: TestClient) -> set[str]:
    state = state_of(client)
    layout = get_layout(services_of(client).db, "demo", state.tag_layout)
    assert layout is not None
    return {p["code"] for p in layout.placed}


def pins_on_wall(client: TestClient, tag_set: str) -> dict[int, str]:
    """Pin number -> code of the set's pins placed on the wall now."""
    on_wall = placed_codes(client)
    prefix = f"brain:{tag_set}:r{BrainState.of(state_of(client)).quiz_round}:pin:"
    return {
        int(name.removeprefix(prefix)): code
        for name, code in brain_codes(client).items()
        if name.startswith(prefix) and code in on_wall
    }


def region_of(client: TestClient, tag_set: TagSetName, number: int) -> Region:
    """The region pin ``number`` marks in the round on the wall (the key: tests only)."""
    app = brain(client)
    quiz_round = app.round_on_wall(services_of(client), "demo", state_of(client))
    assert quiz_round is not None
    return app.pins(quiz_round, tag_set)[number]


def every_pin(client: TestClient, tag_set: str) -> dict[int, str]:
    """Pin number -> code of every pin of a set, turning the brain through the presets."""
    found: dict[int, str] = {}
    for preset in brain(client).views:
        control(client, preset=preset.id)
        found |= pins_on_wall(client, tag_set)
    return found


def answer(client: TestClient, code: str, text: str) -> Any:
    return client.post(
        f"/apps/brain/demo/pins/{code}/answer",
        data={"answer": text, "csrf": csrf_of(client)},
        follow_redirects=False,
    )


def answer_every_pin(client: TestClient, pins: dict[int, str], texts: dict[int, str]) -> None:
    for number, code in sorted(pins.items()):
        response = answer(client, code, texts[number])
        assert response.status_code == 303, response.text


def finish_set(client: TestClient, tag_set: str) -> str:
    client.post(f"/apps/brain/demo/quiz/{tag_set}/finish", data={"csrf": csrf_of(client)})
    return client.get(f"/apps/brain/demo/quiz/{tag_set}").text
