"""The URLs people open: one home for their shape (CLI, dashboard and tests use these)."""

from __future__ import annotations

from webapp.security import operator_token, tile_token
from webapp.settings import Settings


def tile_url(settings: Settings, wall_id: str, tile_id: str) -> str:
    token = tile_token(settings.resolved_secret_key, wall_id)
    return f"{settings.server_url}/wall/{wall_id}/tile/{tile_id}?token={token}"


def overview_url(settings: Settings, wall_id: str) -> str:
    return f"{settings.server_url}/wall/{wall_id}/overview"


def dashboard_url(settings: Settings) -> str:
    return f"{settings.server_url}/dashboard?token={operator_token(settings.resolved_secret_key)}"
