from fastapi.testclient import TestClient

from webapp.app import create_app


def test_healthz() -> None:
    assert TestClient(create_app()).get("/healthz").json() == {"status": "ok"}
