"""Pages from templates: one ``render`` for the core's pages and every app's."""

from __future__ import annotations

from fastapi import Request
from fastapi.responses import HTMLResponse

from webapp.people.security import csrf_token


def render(
    request: Request, template: str, status_code: int = 200, **context: object
) -> HTMLResponse:
    """A page; forms on it get the session's CSRF token as ``csrf``."""
    visitor = getattr(request.state, "visitor", None)
    if visitor is not None:
        secret = request.app.state.services.secret
        context.setdefault("csrf", csrf_token(secret, visitor.session_id))
    context.setdefault("person", getattr(request.state, "person", None))
    response: HTMLResponse = request.app.state.templates.TemplateResponse(
        request, template, context, status_code=status_code
    )
    return response
