"""Imports run one way: a test fails when a cycle or a wrong-way import appears.

Read from the source (module-level imports; ``if TYPE_CHECKING:`` blocks and imports
inside functions are listed apart), so the rules hold whatever Python happens to
import first.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

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


def _is_type_checking(node: ast.stmt) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def runtime_imports(module: str) -> set[str]:
    """What ``module`` imports when it is imported (not only for the type checker)."""
    tree = ast.parse(MODULES[module].read_text())
    found = {name for node in tree.body for name in _imported(node)}
    return found - {module}


GRAPH = {module: runtime_imports(module) for module in MODULES}


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


LOWER_ROOMS = ("webapp.engine", "webapp.tags", "webapp.people", "webapp.database")
UPPER_ROOMS = (
    "webapp.apps.contract",
    "webapp.server.routes",
    "webapp.web.deps",
    "webapp.server.app",
    "webapp.cli.commands",
)


@pytest.mark.parametrize(
    ("rooms", "never", "why"),
    [
        (("tag_service", "wall_client"), ("webapp",), "the pure rules know no web app"),
        (LOWER_ROOMS, UPPER_ROOMS, "the engine, tags, people and database serve the layers above"),
        (
            ("webapp.apps.contract",),
            ("webapp.server.routes", "webapp.server.app", "webapp.cli.commands"),
            "apps plug in below",
        ),
    ],
)
def test_imports_run_one_way(rooms: tuple[str, ...], never: tuple[str, ...], why: str) -> None:
    wrong = sorted(
        f"{module} -> {other}"
        for module, imported in GRAPH.items()
        if _in(module, *rooms)
        for other in imported
        if _in(other, *never)
    )
    assert not wrong, f"{why}: {wrong}"
