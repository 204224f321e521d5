"""Application factory."""

from fastapi import FastAPI


def create_app() -> FastAPI:
    """Build the tagwall ASGI app."""
    app = FastAPI(title="tagwall")

    @app.get("/healthz")
    def healthz() -> dict[str, str]:
        return {"status": "ok"}

    return app
