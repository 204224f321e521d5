"""The limits on what phones do to a shared wall, with the default settings: a lecture
hall behind one NAT address goes through, a phone that drops its cookie does not."""

from __future__ import annotations

from ipaddress import ip_network
from typing import Any, cast

import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from httpx import Response

from tests.conftest import csrf_of, migrate, operator_headers, services_of
from webapp.apps.census_map.app import CensusApp
from webapp.apps.census_map.dataset import DataSet
from webapp.core.settings import Settings
from webapp.engine.wall_state import WallState, read_state
from webapp.people.ratelimit import FLIP_BURST
from webapp.server.app import create_app
from webapp.tags.registry import get_layout, wall_tags

NAT = ("198.51.100.7", 5000)  # the campus NAT every phone of the hall comes from
PHONES = 300


@pytest.fixture
def defaults(settings: Settings) -> Settings:
    """The shipped limits, as a deployment has them (the suite's settle time is 0)."""
    return settings.model_copy(update={"visitor_settle_s": Settings().visitor_settle_s})


@pytest.fixture
def app_with_defaults(defaults: Settings) -> FastAPI:
    migrate(defaults.resolved_database_url)
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


def wall_now(client: TestClient) -> tuple[int, WallState]:
    """The demo wall's version and state."""
    return read_state(services_of(client).db, "demo")


def census_on_the_wall(client: TestClient) -> DataSet:
    """Put the census map on the demo wall; the data set it shows."""
    changed = client.post(
        "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(client)
    )
    assert changed.status_code == 200
    census = cast(CensusApp, services_of(client).apps["census"])
    dataset = census.datasets.current(services_of(client).db)
    assert dataset is not None, "the shipped data set is seeded"
    return dataset


def audience_switches_at_once(client: TestClient) -> None:
    """The brain on the demo wall, the audience allowed to switch its pins, no round
    running (the app's cooldown is the settings' business)."""
    staff = operator_headers(client)
    assert client.post("/api/walls/demo/state", json={"app": "brain"}, headers=staff).is_success
    assert client.post(
        "/api/apps/brain/walls/demo", json={"audience_switches": True}, headers=staff
    ).is_success
    assert client.post("/api/apps/brain/walls/demo/quiz/close", headers=staff).is_success


def refused_clearly(answer: Response) -> None:
    """A refused action: 429 with a page that says how long to wait, as Retry-After does."""
    assert answer.status_code == 429
    wait = answer.headers["Retry-After"]
    assert int(wait) > 0 and f"Try again in {wait} seconds" in answer.text


def took_effect(client: TestClient, method: str, url: str, **request: Any) -> bool:
    """Whether the request was let through; a refused one is refused clearly and leaves
    the wall exactly as it was."""
    before = wall_now(client)
    answer = client.request(method, url, **request)
    if answer.status_code == 200:
        return True
    refused_clearly(answer)
    assert wall_now(client) == before
    return False


def test_a_cookie_dropper_cannot_flicker_the_census_groups(
    app_with_defaults: FastAPI, defaults: Settings
) -> None:
    """Scanning a group toggle from a fresh session each time, fast: new phones of one
    address are one phone to the burst limit, so two toggles reach the wall; the rest
    leave it as it was."""
    with TestClient(app_with_defaults, client=("203.0.113.50", 5000)) as spammer:
        changed = spammer.post(
            "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(spammer)
        )
        assert changed.status_code == 200, changed.text
        toggle = next(t for t in wall_tags(services_of(spammer).db, "demo") if t.action == "toggle")
        flipped = 0
        for _ in range(20):
            spammer.cookies.clear()
            flipped += took_effect(spammer, "GET", f"/t/{toggle.code}")
    assert flipped == FLIP_BURST


def test_a_cookie_dropper_cannot_keep_switching_the_brains_pins(defaults: Settings) -> None:
    """Scanning the K-5 and medical menu codes from a fresh session each time, fast,
    with no cooldown between audience switches: the wall follows the burst new phones
    of one address share. The phone still joins its group (the page says the wall
    waits)."""
    eager = defaults.model_copy(update={"brain_group_switch_cooldown": 0})
    migrate(eager.resolved_database_url)
    with TestClient(create_app(eager), client=("203.0.113.50", 5000)) as spammer:
        audience_switches_at_once(spammer)
        codes = {t.name: t.code for t in wall_tags(services_of(spammer).db, "demo") if t.name}
        switches = 0
        for group in ["k5", "medical"] * 10:
            spammer.cookies.clear()
            before = wall_now(spammer)[1].tag_set
            page = spammer.get(f"/t/{codes[f'brain:group:{group}']}")
            assert page.status_code == 200
            after = wall_now(spammer)[1].tag_set
            switches += after != before
            wanted = "brain-k5" if group == "k5" else "brain-full"
            if before != wanted and after == before:
                assert "switched a moment ago" in page.text, "told that the wall waits"
    assert switches == FLIP_BURST


@pytest.mark.parametrize("settle_s", [10, 0], ids=["new phone", "settled phone"])
def test_a_phones_six_fast_toggles_change_the_wall_at_most_twice(
    defaults: Settings, settle_s: int
) -> None:
    """Well within its per-minute budgets, one phone tapping a group toggle six times
    in a row: the wall shows it on and off, never six flickers; the rest are told to
    wait and leave the wall as it is."""
    settings = defaults.model_copy(update={"visitor_settle_s": settle_s})
    migrate(settings.resolved_database_url)
    with TestClient(create_app(settings), client=NAT) as phone:
        census_on_the_wall(phone)
        group = next(
            str(t.params["group"])
            for t in wall_tags(services_of(phone).db, "demo")
            if t.action == "toggle"
        )
        csrf = csrf_of(phone)
        start = wall_now(phone)[0]
        flipped = [
            took_effect(
                phone, "POST", f"/apps/census/demo/groups/{group}/toggle", data={"csrf": csrf}
            )
            for _ in range(6)
        ]
        assert flipped == [True, True, False, False, False, False]
        assert wall_now(phone)[0] - start == 2


def test_a_phones_six_fast_audience_switches_change_the_wall_at_most_twice(
    defaults: Settings,
) -> None:
    """The brain's menu codes scanned six times in a row by one phone, K-5 and medical
    by turns, with no cooldown between audience switches: two switches reach the wall,
    the phone still joins each group and is told the wall waits."""
    eager = defaults.model_copy(update={"visitor_settle_s": 0, "brain_group_switch_cooldown": 0})
    migrate(eager.resolved_database_url)
    with TestClient(create_app(eager), client=NAT) as phone:
        audience_switches_at_once(phone)
        codes = {t.name: t.code for t in wall_tags(services_of(phone).db, "demo") if t.name}
        start = wall_now(phone)[0]
        pages = [phone.get(f"/t/{codes[f'brain:group:{g}']}") for g in ["k5", "medical"] * 3]
        assert wall_now(phone)[0] - start == 2
        assert [page.status_code for page in pages] == [200] * 6
        for later_k5 in (pages[2], pages[4]):  # the wall shows medical's pins, not K-5's
            assert "switched a moment ago" in later_k5.text, "told that the wall waits"


def test_the_wall_has_one_budget_for_phones_at_every_address(defaults: Settings) -> None:
    """Settled phones, each at its own address and well within its own limits, share
    the wall's budget: past it every phone is told to wait and the wall stays as is."""
    limited = defaults.model_copy(
        update={
            "visitor_settle_s": 0,
            "actions_per_wall_per_minute": 6,
            "trusted_proxies": [ip_network("10.0.0.2")],
        }
    )
    migrate(limited.resolved_database_url)
    with TestClient(create_app(limited), client=("10.0.0.2", 5000)) as proxy:
        dataset = census_on_the_wall(proxy)
        opened = 0
        for phone in range(4):
            proxy.cookies.clear()
            at = {"X-Forwarded-For": f"192.0.2.{phone + 1}"}
            csrf = csrf_of(proxy)
            for tract in dataset.tracts[2 * phone : 2 * phone + 2]:
                opened += took_effect(
                    proxy,
                    "POST",
                    f"/apps/census/demo/tracts/{tract.geoid}/balloon",
                    data={"csrf": csrf},
                    headers=at,
                )
    assert opened == limited.actions_per_wall_per_minute


def test_one_address_has_one_budget_for_all_its_phones(defaults: Settings) -> None:
    """Settled phones behind one address, each within its own limits, share the
    address's budget (here through the toggle form, not the scan)."""
    limited = defaults.model_copy(
        update={"visitor_settle_s": 0, "actions_per_address_per_minute": 4}
    )
    migrate(limited.resolved_database_url)
    with TestClient(create_app(limited), client=NAT) as room:
        changed = room.post(
            "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(room)
        )
        assert changed.status_code == 200
        group = next(
            str(t.params["group"])
            for t in wall_tags(services_of(room).db, "demo")
            if t.action == "toggle"
        )
        flipped = 0
        for _ in range(3):
            room.cookies.clear()
            csrf = csrf_of(room)
            for _ in range(2):
                flipped += took_effect(
                    room, "POST", f"/apps/census/demo/groups/{group}/toggle", data={"csrf": csrf}
                )
        other = ("198.51.100.8", 5000)
        with TestClient(room.app, client=other) as elsewhere:
            answer = elsewhere.post(
                f"/apps/census/demo/groups/{group}/toggle", data={"csrf": csrf_of(elsewhere)}
            )
            assert answer.status_code == 200, "another address has its own budget"
    assert flipped == limited.actions_per_address_per_minute


def test_settled_phones_of_one_address_are_limited_as_themselves(defaults: Settings) -> None:
    """Phones that kept their cookie past the settle time each have their own budget:
    a room publishing together is not one person."""
    settled = defaults.model_copy(update={"visitor_settle_s": 0})
    migrate(settled.resolved_database_url)
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
    proxied = defaults.model_copy(update={"trusted_proxies": [ip_network("10.0.0.2")]})
    migrate(proxied.resolved_database_url)
    with TestClient(create_app(proxied), client=("10.0.0.2", 5000)) as proxy:
        dataset = census_on_the_wall(proxy)
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


def test_server_processes_on_one_redis_hold_one_wall_budget(
    defaults: Settings, redis_server: str, redis_prefix: str
) -> None:
    """Two server processes (two apps, each with its own Redis client) and the wall's
    budget of 6 balloons a minute: phones taking turns between them open 6 in all, and
    the seventh is refused on either process, as one process would refuse it."""
    shared = defaults.model_copy(
        update={
            "bus": "redis",
            "redis_url": redis_server,
            "redis_prefix": redis_prefix,
            "visitor_settle_s": 0,
            "actions_per_wall_per_minute": 6,
        }
    )
    migrate(shared.resolved_database_url)
    with (
        TestClient(create_app(shared), client=NAT) as first,
        TestClient(create_app(shared), client=NAT) as second,
    ):
        changed = first.post(
            "/api/walls/demo/state", json={"app": "census"}, headers=operator_headers(first)
        )
        assert changed.status_code == 200, changed.text
        census = services_of(second).apps["census"]
        dataset = census.datasets.current(services_of(second).db)  # type: ignore[attr-defined]
        statuses = []
        for number, tract in enumerate(dataset.tracts[:8]):
            process = (first, second)[number % 2]
            process.cookies.clear()  # the next phone
            answer = process.post(
                f"/apps/census/demo/tracts/{tract.geoid}/balloon",
                data={"csrf": csrf_of(process)},
            )
            statuses.append(answer.status_code)
            if answer.status_code != 200:
                refused_clearly(answer)
    assert statuses == [200] * 6 + [429, 429]
