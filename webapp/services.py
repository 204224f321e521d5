"""What a running app holds: built by the app factory, reached through ``deps``."""

from __future__ import annotations

from dataclasses import dataclass, field

from anyio import CapacityLimiter

from wall_client.layout import Wall
from webapp.apps import WallApp
from webapp.db import Database
from webapp.hub import WallHub
from webapp.ratelimit import RateLimiter
from webapp.scanning import CodeDirectory, ScanFeed, ScanLog
from webapp.settings import Settings
from webapp.signin import SignInThrottle
from webapp.tokens import Tokens
from webapp.urls import tile_url
from webapp.volume.catalog import VolumeCatalog


@dataclass
class Services:
    settings: Settings
    db: Database
    hub: WallHub
    walls: dict[str, Wall]
    apps: dict[str, WallApp]
    scan_limits: tuple[RateLimiter, RateLimiter] = field(init=False)
    codes: CodeDirectory = field(init=False)
    scan_log: ScanLog = field(init=False)
    scan_feed: ScanFeed = field(init=False)
    login_throttle: SignInThrottle = field(init=False)
    password_checks: CapacityLimiter = field(init=False)
    publish_limit: RateLimiter = field(init=False)
    volumes: VolumeCatalog = field(init=False)
    tokens: Tokens = field(init=False)  # replaced as stored salts change (webapp.tokens)

    def __post_init__(self) -> None:
        self.codes = CodeDirectory(self.db)
        self.scan_log = ScanLog(self.db)
        self.scan_feed = ScanFeed()
        self.scan_limits = (
            RateLimiter(self.settings.scan_rate_per_minute),
            RateLimiter(self.settings.scan_rate_per_address_per_minute),
        )
        self.login_throttle = SignInThrottle(
            self.settings.login_free_attempts,
            self.settings.login_client_free_attempts,
            self.settings.login_max_delay_s,
        )
        # Each argon2 check holds 64 MiB: a burst of sign-ins waits its turn.
        self.password_checks = CapacityLimiter(self.settings.login_parallel_checks)
        self.publish_limit = RateLimiter(self.settings.publish_rate_per_minute)
        self.tokens = Tokens(self.secret)
        self.volumes = VolumeCatalog(
            self.settings.resolved_volume_dir, cache_voxels=self.settings.volume_cache_voxels
        )

    def scan_allowed(self, visitor_id: str, client_address: str) -> float | None:
        """None when this visitor (and its address) may scan now, else seconds to wait."""
        per_visitor, per_address = self.scan_limits
        wait = per_visitor.hit(visitor_id)
        return wait if wait is not None else per_address.hit(client_address)

    @property
    def base_url(self) -> str:
        """Where phones reach this server: the base of every URL code."""
        return self.settings.resolved_public_base_url

    @property
    def secret(self) -> str:
        return self.settings.resolved_secret_key

    def tile_token(self, wall_id: str) -> str:
        return self.tokens.tile(wall_id)

    @property
    def operator_token(self) -> str:
        return self.tokens.operator

    def tile_url(self, wall_id: str, tile_id: str) -> str:
        return tile_url(self.settings, self.tokens, wall_id, tile_id)
