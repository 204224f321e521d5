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
when it succeeds: check and count happen together, so a burst of concurrent
requests gets no more password checks than the throttle allows.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass, field

from itsdangerous import BadSignature, URLSafeSerializer

from webapp.people.ratelimit import Backoff

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


@dataclass
class Attempt:
    """A sign-in attempt counted in advance: the keys it was counted on."""

    counted: list[tuple[Backoff, str]] = field(default_factory=list)
    forget_on_success: list[tuple[Backoff, str]] = field(default_factory=list)


class SignInThrottle:
    """The delays of sign-in attempts, per account at a client, per client, per account
    from unknown browsers, and per known browser."""

    def __init__(self, free: int, client_free: int, max_s: float) -> None:
        self.per_account_at_client = Backoff(free, max_s=max_s)
        self.per_client = Backoff(client_free, max_s=max_s)
        self.per_account = Backoff(ACCOUNT_FREE_CLIENTS, max_s=max_s)
        self.per_device = Backoff(free, max_s=max_s)

    def reserve(self, account: str, address: str, device: str | None) -> Attempt | float:
        """Count an attempt of ``account`` from ``address`` (with a device cookie of that
        account, ``device``) as failed before the password is checked; the seconds to
        wait instead when any of its limits says so."""
        account = account.strip().lower()
        if device is not None:
            keys = [(self.per_device, f"{account}|{device}")]
        else:
            pair = (self.per_account_at_client, f"{account}|{address}")
            keys = [pair, (self.per_client, address)]
            if self.per_account_at_client.failures(pair[1]) == 0:
                keys.append((self.per_account, account))  # each address counts once
            elif (wait := self.per_account.wait(account)) is not None:
                return wait
        waits = [w for backoff, key in keys if (w := backoff.wait(key)) is not None]
        if waits:
            return max(waits)
        for backoff, key in keys:
            backoff.failed(key)
        return Attempt(counted=keys, forget_on_success=keys[:1])

    def succeeded(self, attempt: Attempt) -> None:
        """The password was right: the attempt was no failure, and the account's
        failures from this client (or browser) are forgotten."""
        for backoff, key in attempt.counted:
            backoff.take_back(key)
        for backoff, key in attempt.forget_on_success:
            backoff.succeeded(key)
