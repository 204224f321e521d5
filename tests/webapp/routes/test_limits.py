"""The limits on what phones do to a shared wall, with the default settings: a lecture
hall behind one NAT address goes through, a phone that drops its cookie does not."""

from __future__ import annotations

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from tests.conftest import csrf_of, operator_headers, services_of
from webapp.app import create_app
from webapp.migrate import upgrade
from webapp.settings import Settings
from webapp.tags import get_layout, wall_tags
from webapp.wall_state import read_state

NAT = ("198.51.100.7", 5000)  # the campus NAT every phone of the hall comes from
PHONES = 300


@pytest.fixture
def defaults(settings: Settings) -> Settings:
    """The shipped limits, as a deployment has them (the suite's settle time is 0)."""
    return settings.model_copy(update={"visitor_settle_s": Settings().visitor_settle_s})


@pytest.fixture
def app_with_defaults(defaults: Settings) -> FastAPI:
    upgrade(defaults.resolved_database_url)
    return create_app(defaults)


def placed_pins(client: TestClient) -> list[str]:
    """The brain's pin codes placed on the wall now."""
    db = services_of(client).db
    layout = get_layout(db, "demo", read_state(db, "demo")[1].tag_layout)
    assert layout is not None
    placed = {p["code"] for p in layout.placed}
    return [t.code for t in wall_tags(db, "demo") if t.code in placed and t.action == "pin"]


def test_a_lecture_hall_behind_one_address_registers_and_scans(app_with_defaults: FastAPI) -> None:
    """300 phones arrive through one address (faster than the minute they would take),
    each registers and scans three pins: every page is served."""
    with TestClient(app_with_defaults, client=NAT) as hall:
        shown = hall.post(
            "/api/walls/demo/state", json={"app": "brain"}, headers=operator_headers(hall)
        )
        assert shown.status_code == 200, shown.text
        register = next(
            t.code for t in wall_tags(services_of(hall).db, "demo") if t.name == "register-student"
        )
        pins = placed_pins(hall)[:3]
        assert len(pins) == 3
        refused_registrations = refused_scans = 0
        for _ in range(PHONES):
            hall.cookies.clear()  # the next phone
            refused_registrations += hall.get(f"/t/{register}").status_code == 429
            for pin in pins:
                refused_scans += hall.get(f"/t/{pin}").status_code == 429
    assert (refused_registrations, refused_scans) == (0, 0)


def test_a_phone_that_drops_its_cookie_cannot_flood_the_public_screen(
    app_with_defaults: FastAPI, defaults: Settings
) -> None:
    """Each publication from a brand-new session, with an official-looking name: only
    the small budget new phones of one address share gets through."""
    with TestClient(app_with_defaults, client=("203.0.113.50", 5000)) as spammer:
        code = next(
            t.code for t in wall_tags(services_of(spammer).db, "demo") if t.name == "setup-r2c2"
        )
        published = 0
        for _ in range(20):
            spammer.cookies.clear()
            csrf = csrf_of(spammer)
            name = "\u202eThe Dean\u200b:\nexam\tcancelled" + "!" * 80
            spammer.post(
                "/me",
                data={"csrf": csrf, "display_name": name, "user_group": "k5", "info_class": "1"},
            )
            answer = spammer.post("/publish", data={"code": code, "csrf": csrf})
            assert answer.status_code in (200, 429)
            published += answer.status_code == 200
        item = read_state(services_of(spammer).db, "demo")[1].public
    assert published == defaults.new_visitor_actions_per_address_per_minute
    assert item is not None
    assert "Published by The Dean: exam cancelled!!!!!" in item.html
    assert "!!!!! (student)" in item.html, "names are bounded, and the role shows"
    assert "\u202e" not in item.html and "\u200b" not in item.html


def test_a_cookie_dropper_cannot_fill_the_wall_with_balloons(
    app_with_defaults: FastAPI, defaults: Settings
) -> None:
    with TestClient(app_with_defaults, client=("203.0.113.50", 5000)) as spammer:
        changed = spammer.post(
            "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(spammer)
        )
        assert changed.status_code == 200, changed.text
        census = services_of(spammer).apps["census"]
        dataset = census.datasets.current(services_of(spammer).db)  # type: ignore[attr-defined]
        opened = 0
        for tract in dataset.tracts[:30]:
            spammer.cookies.clear()
            answer = spammer.post(
                f"/apps/census/demo/tracts/{tract.geoid}/balloon",
                data={"csrf": csrf_of(spammer)},
            )
            assert answer.status_code in (200, 429)
            opened += answer.status_code == 200
    assert opened == defaults.new_visitor_actions_per_address_per_minute


def test_settled_phones_of_one_address_are_limited_as_themselves(defaults: Settings) -> None:
    """Phones that kept their cookie past the settle time each have their own budget:
    a room publishing together is not one person."""
    settled = defaults.model_copy(update={"visitor_settle_s": 0})
    upgrade(settled.resolved_database_url)
    with TestClient(create_app(settled), client=NAT) as room:
        code = next(
            t.code for t in wall_tags(services_of(room).db, "demo") if t.name == "setup-r2c2"
        )
        answers = []
        for _ in range(20):
            room.cookies.clear()
            answers.append(room.post("/publish", data={"code": code, "csrf": csrf_of(room)}))
        again = [room.post("/publish", data={"code": code, "csrf": csrf_of(room)}) for _ in "abc"]
    assert [a.status_code for a in answers] == [200] * 20
    per_visitor = settled.publish_rate_per_minute
    assert [a.status_code for a in again] == [200] * (per_visitor - 1) + [429] * (4 - per_visitor)


def test_behind_a_trusted_proxy_each_phone_has_its_own_address(defaults: Settings) -> None:
    """The census routes read the one client address too: phones behind the proxy are
    told apart by X-Forwarded-For, not lumped under the proxy's address."""
    from ipaddress import ip_network

    proxied = defaults.model_copy(update={"trusted_proxies": [ip_network("10.0.0.2")]})
    upgrade(proxied.resolved_database_url)
    with TestClient(create_app(proxied), client=("10.0.0.2", 5000)) as proxy:
        changed = proxy.post(
            "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(proxy)
        )
        assert changed.status_code == 200
        census = services_of(proxy).apps["census"]
        dataset = census.datasets.current(services_of(proxy).db)  # type: ignore[attr-defined]
        budget = proxied.new_visitor_actions_per_address_per_minute
        statuses = []
        for number, tract in enumerate(dataset.tracts[: budget + 4]):
            proxy.cookies.clear()
            phone = {"X-Forwarded-For": f"192.0.2.{number + 1}"}
            csrf = csrf_of(proxy)
            statuses.append(
                proxy.post(
                    f"/apps/census/demo/tracts/{tract.geoid}/balloon",
                    data={"csrf": csrf},
                    headers=phone,
                ).status_code
            )
        assert statuses == [200] * (budget + 4)
