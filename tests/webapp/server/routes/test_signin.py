"""Sign-in throttling as an attacker meets it: failures slow whoever fails, a burst gets
no more password checks than the throttle allows, and argon2 runs a few at a time."""

from __future__ import annotations

import asyncio
import re
import threading
import time
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from tests.conftest import TEST_PASSWORD, csrf_of, migrate, services_of
from webapp.core.settings import Settings
from webapp.database.models import AuditRecord
from webapp.people import accounts
from webapp.people.accounts import add_account
from webapp.people.signin import ACCOUNT_FREE_CLIENTS
from webapp.server.app import create_app

_CSRF = re.compile(r'name="csrf" value="([^"]+)"')


def login(browser: TestClient, password: str, username: str = "ines") -> httpx.Response:
    data = {"username": username, "password": password, "csrf": csrf_of(browser, "/login")}
    return browser.post("/login", data=data, follow_redirects=False)


def checked(app: FastAPI) -> int:
    """Passwords the server checked and found wrong (one audit entry each)."""
    with app.state.services.db.session() as session:
        return int(
            session.scalar(select(func.count()).where(AuditRecord.action == "login_failed")) or 0
        )


def test_an_attacker_elsewhere_does_not_lock_the_instructor_out(app: FastAPI) -> None:
    with (
        TestClient(app, client=("203.0.113.9", 4000)) as attacker,
        TestClient(app, client=("198.51.100.4", 4000)) as instructor,
    ):
        add_account(services_of(attacker).db, "ines", "instructor", TEST_PASSWORD, actor="test")
        answers = [login(attacker, f"guess-number-{i}").status_code for i in range(8)]
        assert answers[:3] == [401, 401, 401] and set(answers[3:]) == {429}
        # the attacker slowed only themselves: even the right password waits there
        assert login(attacker, TEST_PASSWORD).status_code == 429
        signed_in = login(instructor, TEST_PASSWORD)
        assert signed_in.status_code == 303, signed_in.text


def test_a_name_no_account_can_have_is_a_wrong_sign_in(app: FastAPI) -> None:
    """A NUL byte in the name failed PostgreSQL's look-up (a 500 for anyone); the audit
    log keeps the name tried as plain text."""
    with TestClient(app) as browser:
        add_account(services_of(browser).db, "ines", "instructor", TEST_PASSWORD, actor="test")
        assert login(browser, TEST_PASSWORD, "ines\x00").status_code == 401
    with app.state.services.db.session() as session:
        tried = session.scalars(
            select(AuditRecord.actor).where(AuditRecord.action == "login_failed")
        ).all()
    assert tried == ["ines"]


def test_one_address_spraying_many_accounts_is_slowed(app: FastAPI) -> None:
    free = app.state.services.settings.login_client_free_attempts
    with TestClient(app, client=("203.0.113.9", 4000)) as sprayer:
        answers = [login(sprayer, "password1", f"user{i}").status_code for i in range(free + 2)]
    assert answers[:free] == [401] * free
    assert answers[free:] == [429, 429]


async def test_a_burst_of_wrong_sign_ins_gets_no_more_checks_than_allowed(app: FastAPI) -> None:
    """30 requests at once from one browser: the free attempts are checked, the rest
    wait (each attempt is counted before its password is checked)."""
    add_account(app.state.services.db, "ines", "instructor", TEST_PASSWORD, actor="test")
    transport = httpx.ASGITransport(app=app, client=("203.0.113.9", 4000))
    async with httpx.AsyncClient(transport=transport, base_url="http://tagwall") as browser:
        form = await browser.get("/login")
        csrf = _CSRF.search(form.text).group(1)  # type: ignore[union-attr]
        data = {"username": "ines", "password": "not-the-password", "csrf": csrf}
        answers = await asyncio.gather(*(browser.post("/login", data=data) for _ in range(30)))
    free = app.state.services.settings.login_free_attempts
    statuses = sorted(a.status_code for a in answers)
    assert statuses == [401] * free + [429] * (30 - free)
    assert checked(app) == free


async def test_password_checks_run_a_few_at_a_time(
    app: FastAPI, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Sign-ins from many addresses at once (each allowed) queue for argon2, whose
    every check holds 64 MiB: memory stays bounded whatever the burst."""
    running = peak = 0
    lock = threading.Lock()
    real_hasher = accounts._hasher

    class CountingHasher:
        def __init__(self) -> None:
            self.real = real_hasher()

        def verify(self, hashed: str, password: str) -> Any:
            nonlocal running, peak
            with lock:
                running += 1
                peak = max(peak, running)
            try:
                time.sleep(0.05)  # long enough for every request to be waiting by now
                return self.real.verify(hashed, password)
            finally:
                with lock:
                    running -= 1

        def __getattr__(self, name: str) -> Any:
            return getattr(self.real, name)

    monkeypatch.setattr(accounts, "_hasher", CountingHasher)

    async def attempt(number: int) -> int:
        transport = httpx.ASGITransport(app=app, client=(f"198.51.100.{number}", 4000))
        async with httpx.AsyncClient(transport=transport, base_url="http://tagwall") as browser:
            form = await browser.get("/login")
            csrf = _CSRF.search(form.text).group(1)  # type: ignore[union-attr]
            data = {"username": "ines", "password": "wrong-password", "csrf": csrf}
            return (await browser.post("/login", data=data)).status_code

    statuses = await asyncio.gather(*(attempt(n) for n in range(1, 13)))
    assert statuses == [401] * 12, "every one was allowed and checked"
    assert 1 <= peak <= app.state.services.settings.login_parallel_checks


def test_a_known_browser_signs_in_while_the_account_is_guessed_from_everywhere(
    app: FastAPI,
) -> None:
    with TestClient(app, client=("192.0.2.10", 4000)) as laptop:
        add_account(services_of(laptop).db, "ines", "instructor", TEST_PASSWORD, actor="test")
        assert login(laptop, TEST_PASSWORD).status_code == 303  # leaves a device cookie
        laptop.post("/logout", data={"csrf": csrf_of(laptop)})
        for number in range(ACCOUNT_FREE_CLIENTS):  # a guess from each of many addresses
            guesser = TestClient(app, client=(f"203.0.113.{number}", 4000))
            assert login(guesser, "wrong-password").status_code == 401
        unknown_browser = TestClient(app, client=("198.51.100.77", 4000))
        assert login(unknown_browser, TEST_PASSWORD).status_code == 429
        assert login(laptop, TEST_PASSWORD).status_code == 303


def test_failures_on_one_server_process_slow_the_guesser_on_another(
    settings: Settings, redis_server: str, redis_prefix: str
) -> None:
    """Two server processes sharing Redis: a guesser who spreads the attempts over both
    gets the free failures once, not once per process."""
    shared = settings.model_copy(
        update={"bus": "redis", "redis_url": redis_server, "redis_prefix": redis_prefix}
    )
    migrate(shared.resolved_database_url)
    attacker = ("203.0.113.9", 4000)
    with (
        TestClient(create_app(shared), client=attacker) as first,
        TestClient(create_app(shared), client=attacker) as second,
    ):
        add_account(services_of(first).db, "ines", "instructor", TEST_PASSWORD, actor="test")
        answers = [login((first, second)[n % 2], f"guess-{n}").status_code for n in range(6)]
        free = shared.login_free_attempts
        assert answers == [401] * free + [429] * (6 - free)
        assert login(second, TEST_PASSWORD).status_code == 429, "the right password waits too"
