"""Imports run one way: a test fails when a cycle or a wrong-way import appears.

Read from the source, every import counted: at module level, inside functions and in
``if TYPE_CHECKING:`` blocks alike (an import the type checker alone follows still ties
the modules together), so the rules hold whatever Python happens to import first.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

from webapp.core.settings import PROJECT_ROOT

PACKAGES = ("webapp", "wall_client", "tag_service")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PROJECT_ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for pkg in PACKAGES for p in (PROJECT_ROOT / pkg).rglob("*.py")}


def _owner(name: str) -> str | None:
    """The module of ours that ``name`` (a module or a name in one) lives in."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imported(node: ast.stmt) -> Iterator[str]:
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
        names = [f"{node.module}.{alias.name}" for alias in node.names]
        if not all(name in MODULES for name in names):  # names from the module itself
            names.append(node.module)
    else:
        return
    for name in names:
        if name.split(".")[0] in PACKAGES and (owner := _owner(name)):
            yield owner


def imports(module: str) -> set[str]:
    """Every module of ours that ``module`` imports, wherever the import stands."""
    tree = ast.parse(MODULES[module].read_text())
    found = {
        name for node in ast.walk(tree) if isinstance(node, ast.stmt) for name in _imported(node)
    }
    return found - {module}


GRAPH = {module: imports(module) for module in MODULES}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(module: str) -> None:
        index[module] = low[module] = len(index)
        stack.append(module)
        for other in graph[module]:
            if other not in index:
                visit(other)
                low[module] = min(low[module], low[other])
            elif other in stack:
                low[module] = min(low[module], index[other])
        if low[module] == index[module]:
            group = []
            while (top := stack.pop()) != module:
                group.append(top)
            if group:
                found.append(sorted([*group, module]))

    for module in graph:
        if module not in index:
            visit(module)
    return found


def test_no_module_imports_itself_back() -> None:
    assert _cycles(GRAPH) == []


def test_a_cycle_is_found_when_there_is_one() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]


def _in(module: str, *rooms: str) -> bool:
    return any(module == room or module.startswith(room + ".") for room in rooms)


FLOORS = {
    "webapp": 0,  # the package itself; its modules all stand in rooms
    "tag_service": 0,
    "wall_client": 0,
    "webapp.core": 1,
    "webapp.choropleth": 1,
    "webapp.database": 2,
    "webapp.engine": 3,
    "webapp.people": 3,
    "webapp.classes": 3,
    "webapp.campus": 4,
    "webapp.tags": 4,
    "webapp.quiz": 4,
    "webapp.volume": 4,
    "webapp.web": 5,
    "webapp.publishing": 6,
    "webapp.apps": 6,
    "webapp.changes": 7,
    "webapp.server": 8,
    "webapp.cli": 9,
    "webapp.cli.console": 5,  # what every command shares, the apps' commands too
    "webapp.quiz.http": 5,  # what the apps' quiz routes share
}
"""Each room's floor: a module imports only from its own floor and those below. The
engine knows nothing above it; the web layer's context is what apps are given; the wall
changes (their one door) stand above the apps' hooks; the server puts it all together;
the CLI drives it."""


def floor_of(module: str) -> int:
    room = max((r for r in FLOORS if _in(module, r)), key=len, default=None)
    assert room is not None, f"{module} is in no room: add its package to FLOORS"
    return FLOORS[room]


def test_every_module_is_in_a_room() -> None:
    loose = sorted(
        m
        for m in MODULES
        if m.count(".") == 1 and not (PROJECT_ROOT / m.replace(".", "/")).is_dir()
    )
    assert [m for m in loose if m.startswith("webapp.")] == []
    for module in MODULES:
        floor_of(module)


def test_imports_run_down_the_floors() -> None:
    wrong = sorted(
        f"{module} -> {other}"
        for module, imported in GRAPH.items()
        for other in imported
        if floor_of(other) > floor_of(module)
    )
    assert not wrong, f"imports that go up: {wrong}"


APP_PACKAGES = sorted(
    f"webapp.apps.{p.name}"
    for p in (PROJECT_ROOT / "webapp" / "apps").iterdir()
    if (p / "__init__.py").exists()
)


def test_the_core_imports_no_app_and_apps_know_no_other_app() -> None:
    """An app is a plug-in: nothing outside its package imports it, not even the apps'
    hooks or discovery (they find apps through entry points)."""
    wrong = sorted(
        f"{module} -> {other}"
        for module, imported in GRAPH.items()
        for other in imported
        for package in APP_PACKAGES
        if _in(other, package) and not _in(module, package)
    )
    assert not wrong, wrong


def test_the_test_plug_ins_import_only_what_an_app_may() -> None:
    """The apps of tests/plugins are written on the contract alone: from tagwall, only
    the rooms docs/apps.md lets an app import (the poll is what authors copy)."""
    text = (PROJECT_ROOT / "docs" / "apps.md").read_text()
    allowed = text.split("**What an app may import**", 1)[1].split("; never", 1)[0]
    rooms = [name for name in re.findall(r"`([a-z_.]+)`", allowed) if not name.endswith(".md")]
    assert "webapp.quiz" in rooms and "webapp.apps.hooks" in rooms
    plugins = PROJECT_ROOT / "tests" / "plugins"
    wrong = sorted(
        {
            f"{path.relative_to(plugins)} -> {name}"
            for path in plugins.rglob("*.py")
            for node in ast.walk(ast.parse(path.read_text()))
            if isinstance(node, ast.stmt)
            for name in _imported(node)
            if not _in(name, *rooms)
        }
    )
    assert not wrong, wrong
