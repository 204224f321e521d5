"""A tagwall app whose staff sign in at the test OpenID Provider, with a client of the
test's own there."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

import pytest
from fastapi.testclient import TestClient
from httpx import Response

from tests.conftest import migrate
from tests.oidc.provider import Client, OpenIDProvider
from webapp.core.oidc import OIDCProvider
from webapp.core.settings import Settings
from webapp.server.app import create_app


@pytest.fixture
def op_client(openid_provider: OpenIDProvider, settings: Settings) -> Client:
    base = settings.resolved_public_base_url
    return openid_provider.register(f"{base}/login/oidc/campus/callback", f"{base}/")


def with_providers(settings: Settings, **providers: dict[str, Any]) -> Settings:
    return settings.model_copy(
        update={
            "oidc_providers": {
                key: OIDCProvider.model_validate(given) for key, given in providers.items()
            }
        }
    )


@pytest.fixture
def campus_settings(
    settings: Settings, openid_provider: OpenIDProvider, op_client: Client
) -> Settings:
    return with_providers(settings, campus=openid_provider.settings(op_client))


@pytest.fixture
def campus(campus_settings: Settings) -> Iterator[TestClient]:
    """A browser of the app: the provider's answers come back to it."""
    migrate(campus_settings.resolved_database_url)
    with TestClient(create_app(campus_settings)) as client:
        yield client


def begin(client: TestClient, provider: str = "campus", next: str = "/dashboard") -> str:
    """Press the provider's button: the authorization request tagwall sends it to."""
    response = client.get(f"/login/oidc/{provider}", params={"next": next}, follow_redirects=False)
    assert response.status_code == 302, response.text
    return response.headers["location"]


def answer(client: TestClient, redirect: str) -> Response:
    """Follow the provider's redirect back to tagwall (not the redirect after it)."""
    parts = urlsplit(redirect)
    return client.get(f"{parts.path}?{parts.query}", follow_redirects=False)


def sign_in(client: TestClient, provider: OpenIDProvider, login: str) -> Response:
    """Press the button, sign ``login`` in at the provider, and come back."""
    return answer(client, provider.sign_in(begin(client), login))
