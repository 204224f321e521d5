"""The one door for wall-state changes (webapp.changes.door), on both backends.

A small made-up app stands on the wall: its one code is anchored to where the view
looks, so every change of view must move it, and its tag set comes up with it.
"""

from __future__ import annotations

import ast
import asyncio
import json
import threading
import time
from collections.abc import AsyncIterator

import pytest
from fastapi import FastAPI

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp
from webapp.changes.door import unchanged
from webapp.core.settings import CONTENT_DIR, PROJECT_ROOT, Settings
from webapp.engine.wall_state import View, WallState, read_state
from webapp.server.services import Services
from webapp.tags.registry import TagSpec, get_layout, issue
from webapp.web.context import Update

WALL = "demo"
MARKERS = "markers"


class MarkerApp(WallApp):
    """One code where the view's centre lies on the wall; settling sets its mode."""

    name = "marker"
    default_tag_set: str | None = MARKERS
    layers: tuple[str, ...] = ()

    def __init__(self) -> None:
        self.settle_delay_s = 0.0
        self.settled = threading.Event()

    def settle(self, services: Services, wall: Wall, state: WallState) -> WallState:
        self.settled.set()
        time.sleep(self.settle_delay_s)  # a slow app (a volume built on first use)
        return state.model_copy(update={"mode": "marked"})

    def leave(self, state: WallState) -> WallState:
        return state.model_copy(update={"mode": "default"})

    def declare_tags(self, services: Services, wall: Wall, state: WallState) -> list[TagSpec]:
        x, y = state.view.center
        anchor = (wall.stage.x + x * wall.stage.width, wall.stage.y + y * wall.stage.height)
        return [
            TagSpec(
                name="marker",
                label="Here",
                app=self.name,
                action="mark",
                tag_set=MARKERS,
                anchor=anchor,
            )
        ]


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """The demo wall alone: the door's tests need one wall, started quickly."""
    return settings.model_copy(update={"wall_configs": [CONTENT_DIR / "walls" / "demo.toml"]})


@pytest.fixture
async def services(app: FastAPI) -> AsyncIterator[Services]:
    """The app's services with the marker app among its apps, started."""
    found: Services = app.state.services
    found.apps["marker"] = MarkerApp()
    async with app.router.lifespan_context(app):
        yield found


def wall_of(services: Services) -> Wall:
    return services.walls[WALL]


def to_marker(state: WallState) -> WallState:
    return state.model_copy(update={"app": "marker"})


def looking_at(x: float, y: float) -> Update:
    return lambda state: state.model_copy(update={"view": View(center=(x, y))})


def marker_anchor(services: Services, state: WallState) -> tuple[float, float]:
    layout = get_layout(services.db, WALL, state.tag_layout)
    assert layout is not None and layout.tag_set == MARKERS
    (placed,) = [p for p in layout.placed if p["label"] == "Here"]
    return tuple(placed["anchor"])  # type: ignore[return-value]


async def test_a_light_change_commits_and_publishes_without_placing(services: Services) -> None:
    wall = wall_of(services)
    _, before = read_state(services.db, WALL)
    async with services.hub.bus.subscribe(WALL) as inbox:
        change = await services.change_wall(wall, lambda s: s.model_copy(update={"mode": "x"}))
        message = json.loads(await inbox.next())
    assert change is not None and change.changes == {"mode": "x"} and not change.heavy
    assert message["type"] == "event" and message["version"] == change.version
    assert read_state(services.db, WALL)[1].tag_layout == before.tag_layout


async def test_nothing_changed_commits_nothing(services: Services) -> None:
    version, _ = read_state(services.db, WALL)
    assert await services.change_wall(wall_of(services), unchanged) is None
    assert read_state(services.db, WALL)[0] == version


async def test_an_app_coming_on_settles_and_brings_its_codes_in_the_same_change(
    services: Services,
) -> None:
    change = await services.change_wall(wall_of(services), to_marker)
    assert change is not None and change.heavy
    assert {"app", "mode", "tag_set", "tag_layout"} <= change.changes.keys()
    _, state = read_state(services.db, WALL)
    assert state.mode == "marked" and state.tag_set == MARKERS
    stage = wall_of(services).stage
    assert marker_anchor(services, state) == pytest.approx(stage.center)


async def test_a_new_view_moves_the_codes_with_it(services: Services) -> None:
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    change = await services.change_wall(wall, looking_at(0.25, 0.5))
    assert change is not None and {"view", "tag_layout"} <= change.changes.keys()
    _, state = read_state(services.db, WALL)
    x, _ = marker_anchor(services, state)
    assert x == pytest.approx(wall.stage.x + 0.25 * wall.stage.width)


async def test_an_app_coming_on_starts_from_the_default_view(services: Services) -> None:
    """Issue 31: the census came on at the brain's zoom 1.75 and covered the
    registration and public screens until someone pressed "whole map"."""
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    zoomed = View(center=(0.3, 0.6), zoom=1.75)
    await services.change_wall(wall, lambda s: s.model_copy(update={"view": zoomed}))
    change = await services.change_wall(wall, lambda s: s.model_copy(update={"app": "pattern"}))
    assert change is not None and "view" in change.changes
    assert read_state(services.db, WALL)[1].view == View()
    await services.change_wall(wall, lambda s: s.model_copy(update={"view": zoomed}))
    await services.change_wall(wall, to_marker)
    _, state = read_state(services.db, WALL)
    assert state.view == View()
    assert marker_anchor(services, state) == pytest.approx(wall.stage.center), (
        "the codes of the app coming on are placed for its own view"
    )


async def test_a_switch_that_names_a_view_keeps_it(services: Services) -> None:
    wall = wall_of(services)
    await services.change_wall(wall, looking_at(0.5, 0.5))
    named = View(center=(0.25, 0.5), zoom=2.0)
    await services.change_wall(
        wall, lambda s: s.model_copy(update={"app": "marker", "view": named})
    )
    assert read_state(services.db, WALL)[1].view == named


async def test_a_start_keeps_the_view_an_instructor_chose(services: Services) -> None:
    """``settle`` runs at every start too: the pan stays there."""
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    panned = View(center=(0.3, 0.6), zoom=1.75)
    await services.change_wall(wall, lambda s: s.model_copy(update={"view": panned}))
    await services.door.open(wall)
    assert read_state(services.db, WALL)[1].view == panned


async def test_scans_see_codes_that_came_with_a_change_at_once(services: Services) -> None:
    """The scan path's cache is dropped by the door: a code that just came on the wall
    resolves as live without waiting for the cache to expire."""
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    _, state = read_state(services.db, WALL)
    layout = get_layout(services.db, WALL, state.tag_layout)
    assert layout is not None
    (code,) = [p["code"] for p in layout.placed if p["label"] == "Here"]
    assert (await services.codes.resolve(code)).problem is None
    await services.change_wall(wall, lambda s: s.model_copy(update={"app": "pattern"}))
    assert (await services.codes.resolve(code)).problem is not None


async def test_a_tag_issued_is_placed_when_asked_to_replace_codes(services: Services) -> None:
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    _, before = read_state(services.db, WALL)
    spec = TagSpec(label="Extra", app="marker", action="mark", tag_set=MARKERS, anchor=(300, 300))
    issue(services.db, WALL, spec, "test")
    assert await services.change_wall(wall, unchanged) is None  # nothing moved
    change = await services.change_wall(wall, unchanged, replace_codes=True)
    assert change is not None and set(change.changes) == {"tag_layout"}
    layout = get_layout(services.db, WALL, read_state(services.db, WALL)[1].tag_layout)
    assert layout is not None and layout.id != before.tag_layout
    assert "Extra" in {p["label"] for p in layout.placed}


async def test_opening_a_wall_again_changes_nothing(services: Services) -> None:
    version, state = read_state(services.db, WALL)
    assert state.tag_layout, "the start put the wall's codes up"
    assert await services.door.open(wall_of(services)) is None
    assert read_state(services.db, WALL)[0] == version


async def test_a_planned_change_sees_the_wall_as_it_commits(services: Services) -> None:
    wall = wall_of(services)
    seen: list[int] = []

    async def plan(state: WallState) -> Update:
        seen.append(state.tag_layout)
        await asyncio.sleep(0.05)  # another change arriving now must wait
        return lambda current: current.model_copy(update={"mode": f"after {current.tag_layout}"})

    planned = asyncio.create_task(services.plan_change(wall, plan))
    await asyncio.sleep(0.01)
    await services.change_wall(wall, to_marker)
    await planned
    _, state = read_state(services.db, WALL)
    assert state.app == "marker" and state.mode == "marked"  # the app switch came second


async def test_a_tag_set_switch_racing_an_app_switch_does_not_interleave(
    services: Services,
) -> None:
    """The app switch settles slowly; a switch of tag set asked meanwhile waits for it,
    so every committed layout is the one for the state it was committed with."""
    wall = wall_of(services)
    marker: MarkerApp = services.apps["marker"]  # type: ignore[assignment]
    marker.settle_delay_s = 0.3
    issue(
        services.db,
        WALL,
        TagSpec(label="Other", app="pattern", action="locate", tag_set="other", anchor=(200, 200)),
        "test",
    )
    async with services.hub.bus.subscribe(WALL) as inbox:
        switching_app = asyncio.create_task(services.change_wall(wall, to_marker))
        await asyncio.to_thread(marker.settled.wait, 5)
        switching_set = asyncio.create_task(
            services.change_wall(wall, lambda s: s.model_copy(update={"tag_set": "other"}))
        )
        app_change, set_change = await asyncio.gather(switching_app, switching_set)
        frames = [json.loads(await inbox.next()) for _ in range(4)]  # prepare + swap each
    assert app_change is not None and set_change is not None
    assert set_change.version == app_change.version + 1
    prepares = [f for f in frames if f["type"] == "prepare"]
    assert [f["version"] for f in prepares] == [app_change.version, set_change.version]
    for frame in prepares:
        layout = get_layout(services.db, WALL, frame["changes"]["tag_layout"])
        assert layout is not None and layout.tag_set == frame["changes"]["tag_set"]
    _, state = read_state(services.db, WALL)
    assert state.app == "marker" and state.tag_set == "other"


def test_nothing_but_the_door_commits_wall_changes() -> None:
    """Every state change goes through webapp.changes.door: no other module calls the hub's
    commit or the database's commit_change."""
    webapp = PROJECT_ROOT / "webapp"
    callers = set()
    for path in webapp.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            hub_commit = (
                isinstance(node, ast.Attribute)
                and node.attr == "commit"
                and isinstance(node.value, ast.Attribute)
                and node.value.attr == "hub"
            )
            if hub_commit or (isinstance(node, ast.Name) and node.id == "commit_change"):
                callers.add(path.relative_to(webapp).as_posix())
    assert callers == {"changes/door.py", "engine/hub.py"}


async def test_a_wall_left_on_an_app_no_longer_installed_opens_on_the_first_app(
    services: Services,
) -> None:
    wall = wall_of(services)
    await services.change_wall(wall, to_marker)
    del services.apps["marker"]  # uninstalled before the next start
    change = await services.door.open(wall)
    assert change is not None
    _, state = read_state(services.db, wall.id)
    assert state.app == services.settings.first_app == "pattern"
    assert state.tag_set == services.apps["pattern"].default_tag_set
