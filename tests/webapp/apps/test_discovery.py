"""Finding apps: entry points load, and an app that cannot be used says which and why."""

from __future__ import annotations

from importlib.metadata import EntryPoint

import pytest

from webapp.apps.discovery import GROUP, AppLoadError, contract_members, installed_apps, load_app
from webapp.apps.pattern.app import PatternApp


class Nameless:
    """An app that forgot most of the contract."""

    name = "nameless"


class Misnamed(PatternApp):
    name = "other"


class Exploding:
    def __init__(self) -> None:
        raise RuntimeError("no content folder")


def _entry(name: str, target: str) -> EntryPoint:
    return EntryPoint(name=name, value=f"{__name__}:{target}", group=GROUP)


def test_the_built_in_apps_are_found_as_every_other_app_is() -> None:
    apps = installed_apps()
    assert {"core", "pattern", "census", "brain"} <= set(apps)
    assert all(app.name == name for name, app in apps.items())


def test_the_contract_lists_what_every_app_has() -> None:
    members = contract_members()
    assert {"name", "state", "layers", "settle", "declare_tags", "on_scan", "router"} <= set(
        members
    )


def test_an_app_lacking_part_of_the_contract_is_named_with_what_it_lacks() -> None:
    with pytest.raises(AppLoadError, match=r"app 'nameless' .* lacks .*declare_tags"):
        load_app(_entry("nameless", "Nameless"))


def test_an_app_that_fails_to_load_says_why() -> None:
    with pytest.raises(AppLoadError, match=r"app 'exploding' .* could not be loaded: no content"):
        load_app(_entry("exploding", "Exploding"))
    with pytest.raises(AppLoadError, match="could not be loaded"):
        load_app(EntryPoint(name="gone", value="no_such_package.app:App", group=GROUP))


def test_an_app_must_be_called_by_its_entry_points_name() -> None:
    with pytest.raises(AppLoadError, match="calls itself 'other'"):
        load_app(_entry("pattern", "Misnamed"))
