"""What a running app holds: built by the app factory, reached through ``deps``."""

from __future__ import annotations

from dataclasses import dataclass

from wall_client.layout import Wall
from webapp.db import Database
from webapp.hub import WallHub
from webapp.security import operator_token, tile_token
from webapp.settings import Settings
from webapp.urls import tile_url


@dataclass
class Services:
    settings: Settings
    db: Database
    hub: WallHub
    walls: dict[str, Wall]

    @property
    def secret(self) -> str:
        return self.settings.resolved_secret_key

    def tile_token(self, wall_id: str) -> str:
        return tile_token(self.secret, wall_id)

    @property
    def operator_token(self) -> str:
        return operator_token(self.secret)

    def tile_url(self, wall_id: str, tile_id: str) -> str:
        return tile_url(self.settings, wall_id, tile_id)
