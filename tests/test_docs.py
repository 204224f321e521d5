"""The reference docs cover everything a user can meet: a test fails when one does not."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import click
import pytest
from fastapi.testclient import TestClient

from tests.conftest import routes_of
from wall_client.config import config_keys
from webapp.apps.discovery import installed_apps
from webapp.apps.hooks import ATTRIBUTES, HOOKS, WallApp
from webapp.apps.installed import heavy_keys
from webapp.cli.commands import main
from webapp.core.settings import PROJECT_ROOT, Settings
from webapp.engine import protocol
from webapp.engine.wall_state import CORE_HEAVY_KEYS, WallState
from webapp.web.context import AppContext

DOCS = PROJECT_ROOT / "docs"


def section(markdown: str, heading: str) -> str:
    """The text under ``heading`` up to the next heading of the same or higher level."""
    match = re.search(rf"^(#+) {re.escape(heading)}\s*$", markdown, re.MULTILINE)
    assert match, f"no heading {heading!r}"
    level = len(match.group(1))
    rest = markdown[match.end() :]
    end = re.search(rf"^#{{1,{level}}} ", rest, re.MULTILINE)
    return rest[: end.start()] if end else rest


def message_types() -> Iterator[type[protocol.Message]]:
    for model in vars(protocol).values():
        if (
            isinstance(model, type)
            and issubclass(model, protocol.Message)
            and "type" in model.model_fields
        ):
            yield model


@pytest.mark.parametrize("model", list(message_types()), ids=lambda model: model.__name__)
def test_every_message_type_and_field_is_documented(model: type[protocol.Message]) -> None:
    text = (DOCS / "protocol.md").read_text()
    name = model.model_fields["type"].default
    body = section(text, f"`{name}`")
    for field in set(model.model_fields) - {"type"}:
        assert f"`{field}`" in body, f"{name}.{field} is not documented in docs/protocol.md"


def test_every_wall_state_field_is_documented_with_its_weight() -> None:
    body = section((DOCS / "protocol.md").read_text(), "Wall state")
    for field in WallState.model_fields:
        row = re.search(rf"^\| `{field}` \|([^|]*)\|", body, re.MULTILINE)
        assert row, f"wall state field {field} is not documented in docs/protocol.md"
        assert (row.group(1).strip() == "yes") == (field in CORE_HEAVY_KEYS), field


@pytest.mark.parametrize(
    "app", [a for a in installed_apps().values() if a.state], ids=lambda app: app.name
)
def test_every_app_slot_key_is_documented_with_its_weight(app: WallApp) -> None:
    assert app.state is not None
    heavy = heavy_keys({app.name: app})
    body = section((DOCS / "protocol.md").read_text(), "App slots")
    for key in app.state.model_fields:
        row = re.search(rf"^\| `{key}` \|([^|]*)\|", body, re.MULTILINE)
        assert row, f"{app.name}'s slot key {key} is not documented in docs/protocol.md"
        assert (row.group(1).strip() == "yes") == (f"{app.name}.{key}" in heavy), key


def test_the_apps_commands_are_found() -> None:
    paths = {path for path, _ in commands(main)}
    assert {"tagwall census import", "tagwall content check", "tagwall serve"} <= paths


def test_message_types_are_found() -> None:
    names = {model.model_fields["type"].default for model in message_types()}
    assert {"hello", "ping", "ready", "applied", "snapshot", "event", "prepare", "swap"} <= names


def commands(group: click.Group, prefix: str = "tagwall") -> Iterator[tuple[str, click.Command]]:
    """Every command, the apps' included (as ``tagwall --help`` lists them)."""
    context = click.Context(group)
    for name in group.list_commands(context):
        command = group.get_command(context, name)
        assert command is not None
        path = f"{prefix} {name}"
        yield path, command
        if isinstance(command, click.Group):
            yield from commands(command, path)


@pytest.mark.parametrize("path,command", list(commands(main)), ids=lambda value: str(value))
def test_every_command_and_option_is_documented(path: str, command: click.Command) -> None:
    text = (DOCS / "cli.md").read_text()
    assert f"`{path}" in text, f"{path} is not documented in docs/cli.md"
    if isinstance(command, click.Group):
        return
    body = section(text, f"`{path}`")
    for parameter in command.params:
        if isinstance(parameter, click.Option):
            assert parameter.opts[0] in body, f"{path} {parameter.opts[0]} is undocumented"


@pytest.mark.parametrize("name", sorted(Settings.model_fields))
def test_every_setting_is_documented(name: str) -> None:
    text = (DOCS / "configuration.md").read_text()
    assert f"`TAGWALL_{name.upper()}`" in text


def test_readme_links_to_every_reference_doc() -> None:
    readme = (PROJECT_ROOT / "README.md").read_text()
    for doc in sorted(Path(DOCS).glob("*.md")):
        assert f"docs/{doc.name}" in readme, f"README does not link docs/{doc.name}"


def test_every_route_is_listed_in_the_url_reference(client: TestClient) -> None:
    text = (DOCS / "urls.md").read_text()
    missing = [
        f"{method} {path}"
        for method, path in sorted(routes_of(client.app))  # type: ignore[arg-type]
        if method != "HEAD" and f"`{method} {path}`" not in text
    ]
    assert not missing, f"routes missing from docs/urls.md: {missing}"


@pytest.mark.parametrize("key", config_keys())
def test_every_wall_config_key_is_documented(key: str) -> None:
    """Keys come from the pydantic models: a key added there fails here until documented."""
    assert f"`{key}`" in (DOCS / "wall-config.md").read_text(), f"{key} is not documented"


def test_documented_wall_config_keys_are_accepted() -> None:
    """The other direction: the docs' key tables list nothing the models refuse."""
    text = (DOCS / "wall-config.md").read_text()
    rows = re.findall(r"^\| `([a-z_.]+)` \|", text, flags=re.MULTILINE)
    assert rows and set(rows) == set(config_keys())


@pytest.mark.parametrize("name", [*ATTRIBUTES, *HOOKS])
def test_every_hook_and_attribute_of_an_app_is_documented(name: str) -> None:
    body = section((DOCS / "apps.md").read_text(), "The hooks")
    assert re.search(rf"^\| `(async )?{name}[`(]", body, re.MULTILINE), (
        f"{name} is not in docs/apps.md's table of hooks"
    )


@pytest.mark.parametrize(
    "name", [n for n in dir(AppContext) if not n.startswith("_")] + list(AppContext.__annotations__)
)
def test_everything_an_app_is_handed_is_documented(name: str) -> None:
    body = section((DOCS / "apps.md").read_text(), "What an app is handed")
    assert re.search(rf"`(await )?{name}[`(]", body), f"AppContext.{name} is not in docs/apps.md"


POLL_APP = PROJECT_ROOT / "tests" / "plugins" / "poll_app"


def fenced(markdown: str) -> list[str]:
    """The code blocks of ``markdown``, each as written between its fences."""
    return re.findall(r"^```[a-z]*\n(.*?)^```$", markdown, re.MULTILINE | re.DOTALL)


@pytest.mark.parametrize(
    ("doc", "heading"),
    [("apps.md", "A worked example: a poll"), ("quiz.md", "Example: a live poll")],
)
def test_the_poll_example_quotes_the_poll_app_as_it_is(doc: str, heading: str) -> None:
    """The worked example quotes tests/plugins/poll_app: each block word for word."""
    sources = [p for p in POLL_APP.rglob("*") if p.suffix in {".py", ".js", ".html", ".toml"}]
    files = [path.read_text() for path in sources]
    blocks = fenced(section((DOCS / doc).read_text(), heading))
    assert blocks, f"no code in {doc}'s {heading!r}"
    for block in blocks:
        assert any(block in text for text in files), f"not in the poll app:\n{block}"
