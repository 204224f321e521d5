"""Finding apps: entry points load, and an app that cannot be used is refused at start
with one line per problem, naming its distribution, the app and what is wrong.

The apps here are real distributions: a ``.dist-info`` folder and a module written
into a folder put on ``sys.path``, found by ``importlib.metadata`` as ``pip install``
would leave them.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path

import pytest

from webapp.apps.discovery import AppLoadError, installed_apps
from webapp.apps.hooks import ATTRIBUTES, HOOKS, WallApp

Install = Callable[..., None]

HEADER = """
from fastapi import APIRouter, Response
from webapp.apps.hooks import Scan, WallApp
from webapp.engine.wall_state import AppState, WallState
"""


@pytest.fixture
def install(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Install:
    """``install(dist, version, module, source, apps)``: a distribution ``dist`` with a
    module and ``apps`` ({entry point name: "module:Class"}) in the tagwall.apps group."""
    site = tmp_path / "site"
    site.mkdir()
    monkeypatch.syspath_prepend(str(site))

    def installer(dist: str, module: str, source: str, apps: dict[str, str]) -> None:
        (site / f"{module}.py").write_text(HEADER + textwrap.dedent(source))
        info = site / f"{dist.replace('-', '_')}-1.0.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
        lines = "\n".join(f"{name} = {target}" for name, target in apps.items())
        (info / "entry_points.txt").write_text(f"[tagwall.apps]\n{lines}\n")

    return installer


def problems_of(only: tuple[str, ...] = ()) -> list[str]:
    with pytest.raises(AppLoadError) as refused:
        installed_apps(only)
    return refused.value.problems


def test_the_built_in_apps_are_found_as_every_other_app_is() -> None:
    apps = installed_apps()
    assert {"core", "pattern", "census", "brain", "image", "video"} <= set(apps)
    assert all(app.name == name for name, app in apps.items())


def test_every_hook_is_listed_with_its_default() -> None:
    """An app that sets only its name has every hook: the defaults of webapp.apps.hooks."""
    assert {"settle", "declare_tags", "on_scan", "switch_mode", "router", "commands"} <= set(HOOKS)
    assert {"name", "state", "layers", "migrations", "modes"} <= set(ATTRIBUTES)

    class Bare(WallApp):
        name = "bare"

    bare = Bare()
    for hook in HOOKS:
        assert getattr(Bare, hook) is getattr(WallApp, hook), hook
    assert bare.router() is None and bare.commands() == [] and bare.modes == ()


def test_an_app_implements_only_what_it_uses(install: Install) -> None:
    install(
        "tagwall-tiny",
        "tiny_app",
        """
        class Tiny(WallApp):
            name = "tiny"
            layers = ("/static/apps/tiny/tiny.js",)
        """,
        {"tiny": "tiny_app:Tiny"},
    )
    assert installed_apps()["tiny"].layers == ("/static/apps/tiny/tiny.js",)


def test_a_hook_of_another_shape_is_refused_naming_the_distribution_and_hook(
    install: Install,
) -> None:
    install(
        "tagwall-shapes",
        "shapes_app",
        """
        class Shapes(WallApp):
            name = "shapes"

            def on_scan(self, scan):  # sync, where the core awaits it
                return Response("hi")

            async def settle(self, context, wall, state):  # async, where it is called
                return state

            def declare_tags(self, context, state):  # a parameter short
                return []
        """,
        {"shapes": "shapes_app:Shapes"},
    )
    problems = problems_of()
    assert len(problems) == 3, problems
    assert all(
        p.startswith("app 'shapes' (tagwall-shapes 1.0, shapes_app:Shapes): ") for p in problems
    )
    joined = "\n".join(problems)
    assert "hook on_scan must be `async def on_scan(self, scan: 'Scan') -> 'Response'`" in joined
    assert "hook settle must be `def settle(" in joined
    assert "hook declare_tags must be `def declare_tags(self, context" in joined
    assert "not `declare_tags(self, context, state)`" in joined


def test_routes_outside_the_apps_own_prefixes_and_a_slot_of_another_name_are_refused(
    install: Install,
) -> None:
    """A plug-in that would answer the core's sign-in page, its health check or a wall's
    status, and keep its slot under the census map's name: one line each."""
    install(
        "tagwall-rogue",
        "rogue_app",
        """
        class RogueState(AppState):
            app = "census"

        router = APIRouter()

        @router.get("/login")
        async def login() -> str:
            return "no password needed"

        @router.get("/healthz")
        async def health() -> str:
            return "fine"

        @router.get("/api/walls/{wall_id}/status")
        async def status(wall_id: str) -> str:
            return "whatever"

        @router.get("/apps/rogue/fine")
        async def fine() -> str:
            return "its own"

        class Rogue(WallApp):
            name = "rogue"
            state = RogueState

            def router(self):
                return router
        """,
        {"rogue": "rogue_app:Rogue"},
    )
    problems = problems_of()
    where = "app 'rogue' (tagwall-rogue 1.0, rogue_app:Rogue): "
    under = "an app's routes live under /apps/rogue/ and /api/apps/rogue/"
    assert problems == [
        f"{where}keeps its slot under 'census': an app's slot is named after it",
        f"{where}may not answer /api/walls/{{wall_id}}/status: {under}",
        f"{where}may not answer /healthz: {under}",
        f"{where}may not answer /login: {under}",
    ]


def test_two_apps_of_one_name_name_both_distributions(install: Install) -> None:
    source = """
        class Census(WallApp):
            name = "census"
        """
    install("tagwall-census-fork", "census_fork", source, {"census": "census_fork:Census"})
    problems = problems_of()
    assert problems == [
        "two installed apps are called 'census': app 'census' (tagwall-census-fork 1.0,"
        " census_fork:Census) and app 'census' (tagwall 0.1.0,"
        " webapp.apps.census_map.app:CensusApp) (uninstall one, or leave one out of"
        " TAGWALL_APPS)"
    ]


def test_an_app_that_cannot_be_made_or_is_no_wall_app_says_why(install: Install) -> None:
    install(
        "tagwall-broken",
        "broken_app",
        """
        class Exploding(WallApp):
            name = "exploding"

            def __init__(self):
                raise RuntimeError("no content folder")

        class Stranger:
            name = "stranger"

        class Misnamed(WallApp):
            name = "other"
        """,
        {
            "exploding": "broken_app:Exploding",
            "stranger": "broken_app:Stranger",
            "misnamed": "broken_app:Misnamed",
            "gone": "no_such_module:App",
        },
    )
    problems = problems_of()
    assert any(
        "'exploding'" in p and "could not be loaded: no content folder" in p for p in problems
    )
    assert any("'gone'" in p and "could not be loaded: No module named" in p for p in problems)
    assert any("'misnamed'" in p and "calls itself 'other'" in p for p in problems)
    assert any("'stranger'" in p and "is not a webapp.apps.hooks.WallApp" in p for p in problems)
    assert len(problems) == 4


def test_the_allow_list_loads_only_the_apps_it_names_and_the_registration_codes(
    install: Install,
) -> None:
    """One broken plug-in is switched off without uninstalling it (TAGWALL_APPS)."""
    install(
        "tagwall-broken",
        "broken_app",
        """
        class Broken(WallApp):
            name = "broken"

            def on_scan(self, scan):
                return Response("sync")
        """,
        {"broken": "broken_app:Broken"},
    )
    assert problems_of()
    assert set(installed_apps(("brain", "image"))) == {"brain", "image", "core"}
    assert problems_of(("brain", "poll")) == [
        "TAGWALL_APPS names 'poll', which is not installed (installed: brain, broken,"
        " census, core, image, pattern, video)"
    ]
