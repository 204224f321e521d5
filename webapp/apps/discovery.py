"""Finding the installed apps: every ``tagwall.apps`` entry point, the built-in apps too.

A package becomes a tagwall app by naming its app class in its own ``pyproject.toml``::

    [project.entry-points."tagwall.apps"]
    quiz = "my_quiz.app:QuizApp"

and being installed beside tagwall (``pip install``): nothing of tagwall is edited (the
way pytest and datasette find their plugins). An app that cannot be loaded stops the
server with a sentence that names it, rather than leaving a wall without it.
"""

from __future__ import annotations

from importlib.metadata import EntryPoint, entry_points
from typing import get_type_hints

from webapp.apps.contract import WallApp

GROUP = "tagwall.apps"


class AppLoadError(Exception):
    """An installed app that cannot be used; the message says which and why."""


def contract_members() -> list[str]:
    """What every app has: the attributes and methods of :class:`WallApp`."""
    methods = [n for n, v in vars(WallApp).items() if callable(v) and not n.startswith("_")]
    return sorted({*get_type_hints(WallApp), *methods})


def installed_apps() -> dict[str, WallApp]:
    """Every installed app by name, loaded and checked against the contract."""
    found: dict[str, WallApp] = {}
    for entry in sorted(entry_points(group=GROUP), key=lambda e: e.name):
        app = load_app(entry)
        if app.name in found:
            raise AppLoadError(f"two installed apps are called {app.name!r}")
        found[app.name] = app
    return found


def load_app(entry: EntryPoint) -> WallApp:
    """The app an entry point names, made and checked."""
    where = f"app {entry.name!r} ({entry.value})"
    try:
        app = entry.load()()
    except Exception as error:
        raise AppLoadError(f"{where} could not be loaded: {error}") from error
    missing = [member for member in contract_members() if not hasattr(app, member)]
    if missing:
        raise AppLoadError(f"{where} lacks {', '.join(missing)} of the app contract")
    if app.name != entry.name:
        raise AppLoadError(f"{where} calls itself {app.name!r}: the entry point's name must match")
    loaded: WallApp = app
    return loaded
