"""The limits on what phones do to a shared wall, in one home: the budgets each kind of
action meets (:func:`action_limits`, from the settings), the sliding windows that count
them (:class:`ActionLimits`) and the burst rule for flipping the wall's settings.

The counts live in a :class:`~webapp.people.counters.Counters` store: in this process's
memory with one server process, in Redis when several share the wall. Requests meet the
limits through one check, ``webapp.web.deps.limit_action`` (a 429 with Retry-After).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from webapp.core.settings import Settings
from webapp.people.counters.base import Counters, Hit, SlidingWindow

if TYPE_CHECKING:
    from webapp.people.visitors import Visitor


def retry_after_s(wait: float) -> int:
    """The whole seconds a refused request is told to wait (``Retry-After``): past the
    wait, never 0."""
    return int(wait) + 1


WallAction = Literal["scan", "publish", "balloon", "toggle", "group"]
Scope = Literal["visitor", "new", "address", "wall"]

FLIPS: tuple[WallAction, ...] = ("toggle", "group")
FLIP_BURST = 2
FLIP_BURST_S = 10.0
"""What flips a setting of the whole wall (a census group, the audience the brain's pins
are for) does so at most ``FLIP_BURST`` times in ``FLIP_BURST_S`` per phone, and per
address for new phones together, beside the per-minute budgets: a phone's six fast taps
show on the wall as on and off, never as six flickers."""


@dataclass(frozen=True)
class Actor:
    """Who acts, as the abuse limits see them: a visitor (one phone session) at a
    client address; ``age_s`` is how long ago its session cookie was issued (None:
    the request brought no valid cookie)."""

    visitor_id: str
    address: str
    age_s: float | None

    @classmethod
    def of(cls, visitor: Visitor, address: str) -> Actor:
        return cls(visitor.id, address, visitor.age_s())


@dataclass(frozen=True)
class ActionPolicy:
    """How often one kind of action may happen per minute, each limit on its own key:
    per visitor, per client address for visitors not yet settled (a phone whose cookie
    is younger than ``settle_s``, or that brought none), per client address for
    everyone, and per wall. None: no limit of that kind."""

    per_visitor: int
    per_new_address: int | None
    per_address: int | None
    per_wall: int | None
    settle_s: float


class ActionLimits:
    """The limits on what phones do to a wall, one home for every kind of action.

    A phone that drops its cookie is a new visitor at every request: it escapes its
    per-visitor limit but not the small budget that new visitors of one address share.
    A lecture hall behind one NAT address is many settled visitors: each is limited as
    the one phone it is, and only the hall-sized per-address and the wall's own limits
    hold them together.
    """

    def __init__(
        self,
        counters: Counters,
        policies: Mapping[WallAction, ActionPolicy],
        window_s: float = 60.0,
    ) -> None:
        self.counters = counters
        self.policies = dict(policies)
        self._windows: list[tuple[WallAction, Scope, SlidingWindow]] = []
        for kind, policy in self.policies.items():
            scopes: tuple[tuple[Scope, int | None], ...] = (
                ("visitor", policy.per_visitor),
                ("new", policy.per_new_address),
                ("address", policy.per_address),
                ("wall", policy.per_wall),
            )
            for scope, limit in scopes:
                if limit is not None:
                    window = SlidingWindow(f"{kind}:{scope}", limit, window_s)
                    self._windows.append((kind, scope, window))
            if kind in FLIPS:
                for scope in ("visitor", "new"):
                    burst = SlidingWindow(f"{kind}:{scope}:burst", FLIP_BURST, FLIP_BURST_S)
                    self._windows.append((kind, scope, burst))

    async def hit(
        self, kind: WallAction, actor: Actor, wall_id: str, now: float | None = None
    ) -> float | None:
        """Count one action; None when allowed, else the seconds to wait."""
        policy = self.policies[kind]
        settled = actor.age_s is not None and actor.age_s >= policy.settle_s
        keys: dict[Scope, str | None] = {
            "visitor": actor.visitor_id,
            "new": None if settled else actor.address,
            "address": actor.address,
            "wall": wall_id,
        }
        hits: list[Hit] = [
            (window, key)
            for action, scope, window in self._windows
            if action == kind and (key := keys[scope]) is not None
        ]
        return await self.counters.hit(hits, now)


def action_limits(settings: Settings, counters: Counters) -> ActionLimits:
    """The limits on what phones do, from the settings (see docs/people.md).

    Scans change nothing on the wall: a phone with a cookie is limited as itself, and
    only phones without one share their address's budget (a hall's 300 first scans
    fit in it). What changes the shared wall is limited per visitor, for visitors not
    yet settled also per address together, for everyone per address and per wall.
    """
    scans = ActionPolicy(
        per_visitor=settings.scan_rate_per_minute,
        per_new_address=settings.scan_rate_per_address_per_minute,
        per_address=None,
        per_wall=None,
        settle_s=0,
    )

    def on_wall(per_visitor: int) -> ActionPolicy:
        return ActionPolicy(
            per_visitor=per_visitor,
            per_new_address=settings.new_visitor_actions_per_address_per_minute,
            per_address=settings.actions_per_address_per_minute,
            per_wall=settings.actions_per_wall_per_minute,
            settle_s=settings.visitor_settle_s,
        )

    actions = on_wall(settings.wall_action_rate_per_minute)
    return ActionLimits(
        counters,
        {
            "scan": scans,
            "publish": on_wall(settings.publish_rate_per_minute),
            "balloon": actions,
            "toggle": actions,
            "group": actions,
        },
    )
