"""Liveness for load balancers and kiosks: the app answers and its database does."""

from fastapi import APIRouter
from fastapi.responses import JSONResponse

from webapp.server.deps import ServicesDep

router = APIRouter()


@router.get("/healthz")
def healthz(services: ServicesDep) -> JSONResponse:
    if services.db.ping():
        return JSONResponse({"status": "ok"})
    return JSONResponse({"status": "unavailable", "detail": "database unreachable"}, 503)
