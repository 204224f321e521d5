"""How sign-in attempts are throttled, after OWASP's authentication guidance.

Failures slow down who fails, not who is attacked:

* an **account at a client address** gets ``TAGWALL_LOGIN_FREE_ATTEMPTS`` free
  failures, then each further one doubles the wait: a guesser slows only itself, and
  the instructor signing in from another address is not held up;
* a **client address** over all accounts gets ``TAGWALL_LOGIN_CLIENT_FREE_ATTEMPTS``
  (password spraying from one place);
* an **account over many addresses** (a distributed guess) slows down only browsers
  it has never signed in on: every successful sign-in leaves a signed *device
  cookie* naming the account, and a browser that shows one is throttled on its own
  (OWASP's "device cookies"), so the real instructor's usual browser keeps working.

An attempt is counted as failed *before* its password is checked and taken back
when it succeeds: check and count happen together (one operation of the counter store),
so a burst of concurrent requests gets no more password checks than the throttle
allows, on one server process or across all of them (the counts then live in Redis).
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass

from itsdangerous import BadSignature, URLSafeSerializer

from webapp.people.counters.base import Backoff, Counters, Strike

DEVICE_COOKIE = "tagwall_device"
DEVICE_MAX_AGE_S = 365 * 24 * 3600
# Distinct client addresses that may fail on one account before browsers it has never
# signed in on meet delays.
ACCOUNT_FREE_CLIENTS = 20


def _serializer(secret: str) -> URLSafeSerializer:
    return URLSafeSerializer(secret, salt="tagwall.device")


def device_cookie(secret: str, username: str) -> str:
    """The Set-Cookie value that marks this browser as one ``username`` signed in on."""
    value = _serializer(secret).dumps([username, secrets.token_urlsafe(12)])
    return (
        f"{DEVICE_COOKIE}={value}; Max-Age={DEVICE_MAX_AGE_S}; Path=/login; "
        "HttpOnly; SameSite=Strict"
    )


def device_of(secret: str, cookie: str | None, username: str) -> str | None:
    """The device id a browser's cookie proves for ``username`` (None: none, or another
    account's, or forged)."""
    if not cookie or len(cookie) > 300:
        return None
    try:
        value = _serializer(secret).loads(cookie)
    except BadSignature:
        return None
    if isinstance(value, list) and len(value) == 2 and value[0] == username:
        return str(value[1])
    return None


@dataclass(frozen=True)
class Attempt:
    """A sign-in attempt counted in advance: the failures it counted, and those its
    success forgets."""

    counted: tuple[Strike, ...]
    forget_on_success: tuple[Strike, ...]


class SignInThrottle:
    """The delays of sign-in attempts, per account at a client, per client, per account
    from unknown browsers, and per known browser."""

    def __init__(self, counters: Counters, free: int, client_free: int, max_s: float) -> None:
        self.counters = counters
        self.per_account_at_client = Backoff("signin:account-at-client", free, max_s=max_s)
        self.per_client = Backoff("signin:client", client_free, max_s=max_s)
        self.per_account = Backoff("signin:account", ACCOUNT_FREE_CLIENTS, max_s=max_s)
        self.per_device = Backoff("signin:device", free, max_s=max_s)

    async def reserve(
        self, account: str, address: str, device: str | None, now: float | None = None
    ) -> Attempt | float:
        """Count an attempt of ``account`` from ``address`` (with a device cookie of that
        account, ``device``) as failed before the password is checked; the seconds to
        wait instead when any of its limits says so."""
        account = account.strip().lower()
        if device is not None:
            strikes = [Strike(self.per_device, f"{account}|{device}")]
        else:
            pair = Strike(self.per_account_at_client, f"{account}|{address}")
            # the account counts each address once, when it first fails there
            strikes = [
                pair,
                Strike(self.per_client, address),
                Strike(self.per_account, account, once_per=pair),
            ]
        counted = await self.counters.fail(strikes, now)
        if isinstance(counted, float):
            return counted
        return Attempt(counted=counted, forget_on_success=(strikes[0],))

    async def reserve_client(self, address: str, now: float | None = None) -> Attempt | float:
        """Count a campus sign-in's answer from ``address`` as failed before it is
        checked (the provider's answer names the account only once it is): the
        client's limit alone, since one per provider would let anyone who fails often
        enough slow down every browser's campus sign-in."""
        counted = await self.counters.fail([Strike(self.per_client, address)], now)
        if isinstance(counted, float):
            return counted
        return Attempt(counted=counted, forget_on_success=())

    async def succeeded(self, attempt: Attempt) -> None:
        """The password was right: the attempt was no failure, and the account's
        failures from this client (or browser) are forgotten."""
        await self.counters.forgive(attempt.counted, attempt.forget_on_success)
