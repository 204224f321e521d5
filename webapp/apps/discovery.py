"""Finding the installed apps: every ``tagwall.apps`` entry point, the built-in apps too.

A package becomes a tagwall app by naming its app class in its own ``pyproject.toml``::

    [project.entry-points."tagwall.apps"]
    poll = "tagwall_poll.app:PollApp"

and being installed beside tagwall (``pip install``): nothing of tagwall is edited (the
way pytest and datasette find their plugins). ``TAGWALL_APPS`` names the apps to load
when not all of them (datasette's ``DATASETTE_LOAD_PLUGINS``): one broken app is
switched off without uninstalling it.

Every app is checked here as it loads, against :mod:`webapp.apps.hooks`: an app that
cannot be used stops the server with one line per problem, each naming the
distribution and the app, rather than leaving a wall without it or letting it answer a
path of the core's.
"""

from __future__ import annotations

import inspect
from collections.abc import Collection, Iterable
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path

from fastapi.routing import iter_route_contexts

from webapp.apps.hooks import HOOKS, WallApp, route_prefixes
from webapp.apps.installed import REGISTRATION
from webapp.engine.wall_state import AppState

GROUP = "tagwall.apps"


class AppLoadError(Exception):
    """Installed apps that cannot be used: one line per problem, each naming the
    distribution and the app."""

    def __init__(self, problems: Iterable[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


def installed_apps(only: Collection[str] = ()) -> dict[str, WallApp]:
    """Every installed app by name (or those named in ``only``, and the registration
    codes' app, which every wall carries), loaded and checked."""
    entries = sorted(entry_points(group=GROUP), key=lambda e: (e.name, e.value))
    problems = [
        f"TAGWALL_APPS names {name!r}, which is not installed"
        f" (installed: {', '.join(sorted({e.name for e in entries}))})"
        for name in sorted(set(only) - {e.name for e in entries})
    ]
    found: dict[str, tuple[EntryPoint, WallApp]] = {}
    for entry in entries:
        if only and entry.name not in only and entry.name != REGISTRATION:
            continue
        if entry.name in found:
            first, _ = found[entry.name]
            problems.append(
                f"two installed apps are called {entry.name!r}: {where(first)} and {where(entry)}"
                " (uninstall one, or leave one out of TAGWALL_APPS)"
            )
            continue
        try:
            found[entry.name] = (entry, load_app(entry))
        except AppLoadError as error:
            problems.extend(error.problems)
    if problems:
        raise AppLoadError(problems)
    return {name: app for name, (_, app) in found.items()}


def where(entry: EntryPoint) -> str:
    """The app of ``entry`` as a person finds it: its distribution and entry point."""
    dist = entry.dist
    package = f"{dist.metadata['Name']} {dist.version}" if dist is not None else "no distribution"
    return f"app {entry.name!r} ({package}, {entry.value})"


def load_app(entry: EntryPoint) -> WallApp:
    """The app an entry point names, made and checked."""
    try:
        app = entry.load()()
    except Exception as error:
        raise AppLoadError([f"{where(entry)} could not be loaded: {error}"]) from error
    if not isinstance(app, WallApp):
        raise AppLoadError([f"{where(entry)} is not a webapp.apps.hooks.WallApp"])
    problems = check_app(app, entry.name)
    if problems:
        raise AppLoadError(f"{where(entry)}: {problem}" for problem in problems)
    return app


def check_app(app: WallApp, name: str) -> list[str]:
    """What keeps ``app`` (installed as ``name``) from being used, one problem each."""
    problems = []
    if app.name != name:
        problems.append(f"calls itself {app.name!r}: the entry point's name must be the app's")
    problems += _attribute_problems(app)
    problems += [p for hook in HOOKS if (p := _hook_problem(app, hook))]
    problems += _route_problems(app)
    return problems


def _attribute_problems(app: WallApp) -> list[str]:
    problems = []
    slot = app.state
    if slot is not None and not (isinstance(slot, type) and issubclass(slot, AppState)):
        problems.append("state must be an AppState model (or None)")
    elif slot is not None and slot.app != app.name:
        problems.append(f"keeps its slot under {slot.app!r}: an app's slot is named after it")
    if not all(isinstance(layer, str) for layer in app.layers):
        problems.append("layers must be module URLs")
    if not all(isinstance(mode, str) and mode for mode in app.modes):
        problems.append("modes must be names")
    for folder in ("templates", "static", "migrations"):
        path = getattr(app, folder)
        if path is not None and not (isinstance(path, Path) and path.is_dir()):
            problems.append(f"{folder} {path} is not a folder")
    return problems


def _hook_problem(app: WallApp, hook: str) -> str | None:
    """Whether ``app`` implements ``hook`` as the hook is called: sync or async as
    specified, with the specified parameters."""
    spec = getattr(WallApp, hook)
    implementation = getattr(type(app), hook)
    if implementation is spec:
        return None
    expected = inspect.signature(spec)
    wanted = f"{'async ' if inspect.iscoroutinefunction(spec) else ''}def {hook}{expected}"
    if not callable(implementation) or inspect.iscoroutinefunction(
        implementation
    ) != inspect.iscoroutinefunction(spec):
        return f"hook {hook} must be `{wanted}`"
    try:
        given = inspect.signature(implementation)
    except (TypeError, ValueError):
        return None  # a builtin or C callable: trust it
    if list(given.parameters) != list(expected.parameters):
        return f"hook {hook} must be `{wanted}`, not `{hook}{given}`"
    return None


def _route_problems(app: WallApp) -> list[str]:
    """Every path of the app's router lies under its own prefixes, so it never answers
    a path of the core's or of another app."""
    router = app.router()
    if router is None:
        return []
    prefixes = route_prefixes(app.name)
    paths = {route.path or "" for route in iter_route_contexts(router.routes)}
    outside = sorted(path for path in paths if not path.startswith(prefixes))
    return [
        f"may not answer {path}: an app's routes live under {' and '.join(prefixes)}"
        for path in outside
    ]
