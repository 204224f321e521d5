"""Where a request comes from, and which address rule covers it.

The client address middleware (:mod:`webapp.web.middleware`) is the one place that
decides a connection's client address (and scheme) for HTTP and websockets alike: the
peer's, or behind a proxy listed in ``TAGWALL_TRUSTED_PROXIES`` the one its
``X-Forwarded-For`` names. Everything else reads :func:`address_of`. The ASGI server
must not rewrite them first, so ``tagwall serve`` runs uvicorn without its proxy headers.

An address is a weak identity (a whole school may share one NAT address), so rules
give defaults freely but grant a role only when the deployment switches that on
(``TAGWALL_ADDRESS_RULES_GRANT_ROLES``).
"""

from __future__ import annotations

import asyncio
import ipaddress
import time
from collections.abc import Sequence
from ipaddress import IPv4Address, IPv4Network, IPv6Address, IPv6Network
from typing import Any, TypeVar

from sqlalchemy import Connection, Row, select
from starlette.requests import HTTPConnection

from webapp.database.models import AddressRuleRecord
from webapp.engine.bus.base import EventBus
from webapp.engine.bus.forgetting import Forgetting

Network = IPv4Network | IPv6Network
Rule = TypeVar("Rule", AddressRuleRecord, Row[Any])
"""An address rule as a record, or as the row a phone's request reads."""
Address = IPv4Address | IPv6Address


def _address(text: str) -> Address | None:
    try:
        return ipaddress.ip_address(text.strip())
    except ValueError:
        return None


def client_address(peer: str, forwarded_for: str | None, trusted: Sequence[Network]) -> str:
    """The client's address: the peer's, unless the peer is a trusted proxy.

    Behind trusted proxies, ``X-Forwarded-For`` is read from the right (the entries
    our own proxies appended) to the first address that is not a trusted proxy;
    anything left of it was written by the client and proves nothing.
    """
    peer_address = _address(peer)
    if not trusted or peer_address is None or not _is_trusted(peer_address, trusted):
        return peer
    hops = [hop for hop in (forwarded_for or "").split(",") if hop.strip()]
    for hop in reversed(hops):
        address = _address(hop)
        if address is None:
            return peer  # a garbled header: fall back to what we know
        if not _is_trusted(address, trusted):
            return str(address)
    return peer


def is_trusted_peer(peer: str, trusted: Sequence[Network]) -> bool:
    """Whether ``peer`` is one of the proxies whose forwarding headers count."""
    address = _address(peer)
    return address is not None and _is_trusted(address, trusted)


def address_of(connection: HTTPConnection) -> str:
    """The client address of a request or websocket (set by the client address middleware)."""
    return connection.client.host if connection.client else ""


def _is_trusted(address: Address, trusted: Sequence[Network]) -> bool:
    return any(address in network for network in trusted if network.version == address.version)


def parse_network(text: str) -> Network:
    """A CIDR network (``10.1.0.0/16``; a bare address is a /32 or /128)."""
    try:
        return ipaddress.ip_network(text.strip(), strict=False)
    except ValueError:
        raise ValueError(f"{text!r} is not an address or network like 10.1.0.0/16") from None


def matching_rule(address: str, rules: Sequence[Rule]) -> Rule | None:
    """The most specific rule whose network holds ``address`` (None when none does)."""
    parsed = _address(address)
    if parsed is None:
        return None
    best: tuple[int, Rule] | None = None
    for rule in rules:
        network = parse_network(rule.network)
        inside = network.version == parsed.version and parsed in network
        if inside and (best is None or network.prefixlen > best[0]):
            best = (network.prefixlen, rule)
    return best[1] if best else None


_RULES = select(AddressRuleRecord.__table__)  # built once (see Database.reading)
RULES = "address_rules"
"""The bus channel on which a process says it changed address rules."""


def read_rules(connection: Connection) -> Sequence[Row[Any]]:
    """Every address rule, read now."""
    return connection.execute(_RULES).all()


class AddressRules:
    """The address rules as every request's person is matched against them: read at
    most once per ``ttl_s`` (reading them was half of loading a person, and they change
    only when an admin changes one), dropped in every process at once by :meth:`forget`;
    ``ttl_s`` bounds how stale they are when that word is lost. One per app instance."""

    def __init__(self, ttl_s: float = 2.0, bus: EventBus | None = None) -> None:
        self.ttl_s = ttl_s
        self._held: tuple[Sequence[Row[Any]], float] | None = None  # rules, read at
        self._generation = 0  # bumped by a drop: reads begun before it are not kept
        self._forgetting = Forgetting(bus, RULES, self._drop)

    def now(self, connection: Connection) -> Sequence[Row[Any]]:
        """The rules, read on ``connection`` when none younger than ``ttl_s`` are held."""
        held = self._held
        started = time.monotonic()
        if held is not None and started - held[1] <= self.ttl_s:
            return held[0]
        generation = self._generation
        rules = read_rules(connection)
        if generation == self._generation:
            self._held = (rules, started)
        return rules

    def forget(self) -> None:
        """An address rule changed here: drop the rules held in every process (callable
        from a worker thread too)."""
        self._forgetting.forget()

    async def follow(self, opened: asyncio.Event | None = None) -> None:
        """Hear the other processes' :meth:`forget` until cancelled (the app's lifespan)."""
        await self._forgetting.follow(opened)

    def _drop(self) -> None:
        self._generation += 1
        self._held = None
