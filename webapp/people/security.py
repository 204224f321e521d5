"""Tokens derived from the secret key: one per wall for tiles, one for the operator."""

from __future__ import annotations

import base64
import hashlib
import hmac


def derive_token(secret: str, purpose: str) -> str:
    """A stable, unguessable token for ``purpose`` (changes when the secret changes)."""
    digest = hmac.new(secret.encode(), purpose.encode(), hashlib.sha256).digest()
    return base64.b32encode(digest[:15]).decode().lower()


def _salted(purpose: str, salt: str) -> str:
    return f"{purpose}:{salt}" if salt else purpose


def tile_token(secret: str, wall_id: str, salt: str = "") -> str:
    """The token every tile of ``wall_id`` presents; tiles receive, they never command.
    ``salt`` is the wall's stored tile salt (see ``webapp.people.tokens``; "" until rotated)."""
    return derive_token(secret, _salted(f"tile:{wall_id}", salt))


def operator_token(secret: str, salt: str = "") -> str:
    """The token of the setup operator (until instructor accounts take over)."""
    return derive_token(secret, _salted("operator", salt))


def token_matches(expected: str, given: str | None) -> bool:
    """Constant-time comparison, so timing reveals nothing about the token."""
    return given is not None and hmac.compare_digest(expected.encode(), given.encode())


def csrf_token(secret: str, session_id: str) -> str:
    """The token every state-changing form of a session carries (rotates with it)."""
    return derive_token(secret, f"csrf:{session_id}")
