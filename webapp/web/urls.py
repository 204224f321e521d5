"""The URLs people open: one home for their shape (CLI, dashboard and tests use these)."""

from __future__ import annotations

from tag_service.codes import content_hash
from webapp.core.settings import Settings
from webapp.people.tokens import Tokens


def tile_path(token: str, wall_id: str, tile_id: str) -> str:
    """A tile page's path with the wall's tile token; the tile's websocket is the same
    under ``/ws``."""
    return f"/wall/{wall_id}/tile/{tile_id}?token={token}"


def tile_url(settings: Settings, tokens: Tokens, wall_id: str, tile_id: str) -> str:
    return settings.server_url + tile_path(tokens.tile(wall_id), wall_id, tile_id)


def overview_url(settings: Settings, wall_id: str) -> str:
    return f"{settings.server_url}/wall/{wall_id}/overview"


def dashboard_url(settings: Settings, tokens: Tokens) -> str:
    """The operator's sign-in link: it signs the browser in as admin and opens the
    dashboard (for a new installation, before any account exists). On this machine's
    loopback where the server listens there: the token never crosses the network."""
    return f"{settings.local_url}/login/operator?token={tokens.operator}"


def code_image_path(code: str, payload: str, extension: str) -> str:
    """A code's image under a name that changes with its payload (so it caches for good)."""
    return f"/codes/{code}.{content_hash(payload, 'M')}.{extension}"
