"""Routes any site's page may read: their answers and errors say so, and a preflight is
answered; other routes stay closed to other sites."""

from __future__ import annotations

from typing import Annotated

import pytest
from fastapi import APIRouter, FastAPI, HTTPException, Query
from fastapi.testclient import TestClient

from webapp.web.cors import PREFLIGHT_MAX_AGE_S, AnyOriginRoute

OTHER_SITE = {"Origin": "https://viewer.example"}


@pytest.fixture
def client() -> TestClient:
    app = FastAPI()
    open_router = APIRouter(route_class=AnyOriginRoute)

    @open_router.get("/open/{name}")
    async def open_thing(name: str, size: Annotated[int, Query(ge=1)] = 1) -> dict[str, str]:
        if name == "missing":
            raise HTTPException(404, "No such thing.")
        return {"name": name}

    closed = APIRouter()

    @closed.get("/closed")
    async def closed_thing() -> dict[str, str]:
        return {}

    app.include_router(open_router)
    app.include_router(closed)
    return TestClient(app)


@pytest.mark.parametrize(
    ("url", "status"), [("/open/a", 200), ("/open/missing", 404), ("/open/a?size=0", 422)]
)
def test_answers_and_errors_are_readable_from_any_site(
    client: TestClient, url: str, status: int
) -> None:
    response = client.get(url, headers=OTHER_SITE)
    assert response.status_code == status
    assert response.headers["access-control-allow-origin"] == "*"
    assert "access-control-allow-credentials" not in response.headers


def test_a_preflight_is_answered_for_the_routes_methods_and_the_headers_asked(
    client: TestClient,
) -> None:
    response = client.options(
        "/open/a",
        headers={
            **OTHER_SITE,
            "Access-Control-Request-Method": "GET",
            "Access-Control-Request-Headers": "x-requested-with",
        },
    )
    assert response.status_code == 204
    assert response.headers["access-control-allow-origin"] == "*"
    assert "GET" in response.headers["access-control-allow-methods"].split(", ")
    assert response.headers["access-control-allow-headers"] == "x-requested-with"
    assert response.headers["access-control-max-age"] == str(PREFLIGHT_MAX_AGE_S)
    assert "access-control-allow-credentials" not in response.headers


def test_other_routes_stay_closed_to_other_sites(client: TestClient) -> None:
    assert "access-control-allow-origin" not in client.get("/closed", headers=OTHER_SITE).headers
    assert client.options("/closed", headers=OTHER_SITE).status_code == 405
    assert client.post("/open/a", headers=OTHER_SITE).status_code == 405
