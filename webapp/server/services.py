"""What a running server holds: built by the app factory, reached through ``deps``.

:class:`Services` is the one implementation of the context apps are handed
(:class:`~webapp.web.context.AppContext`): its wall changes go through the door.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from anyio import CapacityLimiter
from redis.asyncio import Redis

from wall_client.layout import Wall
from webapp.apps.hooks import WallApp
from webapp.apps.installed import wall_apps
from webapp.campus.oidc import CampusSignIn
from webapp.changes.door import WallDoor
from webapp.core.caching import SizedCache
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import TagLayoutRecord
from webapp.engine.hub import WallHub
from webapp.engine.wall_state import Change, WallState, read_state
from webapp.people.addresses import AddressRules
from webapp.people.counters.base import Counters
from webapp.people.counters.memory import MemoryCounters
from webapp.people.counters.redis import RedisCounters
from webapp.people.ratelimit import ActionLimits, Actor, WallAction, action_limits
from webapp.people.signin import SignInThrottle
from webapp.people.tokens import Tokens
from webapp.people.visitors import Visitor
from webapp.tags.registry import LAYOUTS_KEPT, get_layout
from webapp.tags.scanning import CodeDirectory, ScanFeed, ScanLog
from webapp.volume.catalog import VolumeCatalog
from webapp.web.context import Plan, Update
from webapp.web.urls import tile_url

LAYOUTS_CACHED = 4 * LAYOUTS_KEPT


@dataclass
class Services:
    settings: Settings
    db: Database
    hub: WallHub
    walls: dict[str, Wall]
    apps: dict[str, WallApp]
    # This process's Redis client when several processes serve the walls (TAGWALL_BUS=redis).
    redis: Redis | None = None
    counters: Counters = field(init=False)
    limits: ActionLimits = field(init=False)
    codes: CodeDirectory = field(init=False)
    address_rules: AddressRules = field(init=False)
    scan_log: ScanLog = field(init=False)
    scan_feed: ScanFeed = field(init=False)
    login_throttle: SignInThrottle = field(init=False)
    password_checks: CapacityLimiter = field(init=False)
    campus: CampusSignIn = field(init=False)
    volumes: VolumeCatalog = field(init=False)
    tokens: Tokens = field(init=False)  # replaced as stored salts change (webapp.people.tokens)
    layouts: SizedCache[TagLayoutRecord] = field(init=False)
    door: WallDoor = field(init=False)

    def __post_init__(self) -> None:
        self.codes = CodeDirectory(self.db, bus=self.hub.bus)
        self.address_rules = AddressRules(bus=self.hub.bus)
        self.scan_log = ScanLog(self.db)
        self.scan_feed = ScanFeed(self.hub.bus)
        self.counters = counter_store(self.redis, self.settings)
        self.limits = action_limits(self.settings, self.counters)
        self.login_throttle = SignInThrottle(
            self.counters,
            self.settings.login_free_attempts,
            self.settings.login_client_free_attempts,
            self.settings.login_max_delay_s,
        )
        # Each argon2 check holds 64 MiB: a burst of sign-ins waits its turn (per process:
        # what it bounds is this process's memory).
        self.password_checks = CapacityLimiter(self.settings.login_parallel_checks)
        self.campus = CampusSignIn(self.settings)
        self.tokens = Tokens(self.secret)
        self.layouts = SizedCache(LAYOUTS_CACHED)
        self.volumes = VolumeCatalog(
            self.settings.resolved_volume_dir, cache_voxels=self.settings.volume_cache_voxels
        )
        self.door = WallDoor(
            self, self.hub, self.apps, self.settings.first_app, lambda: self.base_url
        )

    async def state(self, wall: Wall) -> WallState:
        _, state = await self.db.read(read_state, self.db, wall.id)
        return state

    @property
    def installed(self) -> frozenset[str]:
        return frozenset(self.apps)

    def app(self, name: str) -> WallApp:
        return self.apps[name]

    async def change_wall(
        self, wall: Wall, update: Update, *, replace_codes: bool = False
    ) -> Change | None:
        return await self.door.change(wall, update, replace_codes=replace_codes)

    async def plan_change(
        self, wall: Wall, plan: Plan, *, replace_codes: bool = False
    ) -> Change | None:
        return await self.door.plan(wall, plan, replace_codes=replace_codes)

    async def shown_at(self, wall: Wall, version: int) -> int | None:
        return await self.hub.shown_at(wall.id, version)

    async def action_allowed(
        self, kind: WallAction, visitor: Visitor, address: str, wall_id: str = ""
    ) -> float | None:
        """None when this visitor at ``address`` may do ``kind`` on the wall now, else
        the seconds to wait (counted when allowed)."""
        return await self.limits.hit(kind, Actor.of(visitor, address), wall_id)

    @property
    def wall_apps(self) -> dict[str, WallApp]:
        """The apps a wall can show (the registration codes' app only adds its codes)."""
        return wall_apps(self.apps)

    @property
    def base_url(self) -> str:
        """Where phones reach this server: the base of every URL code."""
        return self.settings.resolved_public_base_url

    @property
    def secret(self) -> str:
        return self.settings.resolved_secret_key

    def layout(self, wall_id: str, layout_id: int | None) -> TagLayoutRecord | None:
        """The wall's layout ``layout_id`` (None: no such layout of this wall). Layouts
        never change (a new placement is a new row), so they are kept once read: a
        phone's page may read where its code stands, each parse costing milliseconds.
        Thread-safe; the records are detached and only read."""
        if not layout_id:
            return None
        key = (wall_id, layout_id)
        record = self.layouts.get(key)
        if record is None and (record := get_layout(self.db, wall_id, layout_id)) is not None:
            self.layouts.put(key, record)
        return record

    def tile_token(self, wall_id: str) -> str:
        return self.tokens.tile(wall_id)

    @property
    def operator_token(self) -> str:
        return self.tokens.operator

    def tile_url(self, wall_id: str, tile_id: str) -> str:
        return tile_url(self.settings, self.tokens, wall_id, tile_id)


def counter_store(redis: Redis | None, settings: Settings) -> Counters:
    """Where the abuse limits and the sign-in throttle count: in Redis when several
    processes share the walls (each would otherwise allow the whole budget), else in
    this process."""
    if redis is None:
        return MemoryCounters()
    return RedisCounters(redis, settings.redis_prefix)
