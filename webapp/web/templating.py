"""Pages from templates: one template search path and one ``render`` for the core's pages
and every app's.

Every page that runs modules (its ``modules`` block) carries the import map first: browser
modules import the core's library modules as ``tagwall/<module>.js`` (``static/js/``), so
an app's modules name no server path of the core's. The map is inline, allowed by its hash
in the content security policy; pages without script carry none.
"""

from __future__ import annotations

import base64
import hashlib
import json
from pathlib import Path

from fastapi import Request
from fastapi.responses import HTMLResponse
from fastapi.templating import Jinja2Templates

from webapp.core.markdown import markdown_html, markdown_inline
from webapp.people.security import csrf_token

TEMPLATES_DIR = Path(__file__).parent / "templates"
IMPORT_MAP = json.dumps({"imports": {"tagwall/": "/static/js/"}}, separators=(",", ":"))
IMPORT_MAP_HASH = (
    "sha256-" + base64.b64encode(hashlib.sha256(IMPORT_MAP.encode()).digest()).decode()
)
"""The import map's hash, the one inline script the content security policy allows."""


def make_templates(app_folders: list[Path]) -> Jinja2Templates:
    """The core's templates and every app's folder (each under its app's name)."""
    templates = Jinja2Templates(directory=[TEMPLATES_DIR, *app_folders])
    templates.env.auto_reload = False  # no stat() of every template per page
    templates.env.filters["markdown"] = markdown_html
    templates.env.filters["markdown_inline"] = markdown_inline
    templates.env.globals["import_map"] = IMPORT_MAP
    return templates


def render(
    request: Request, template: str, status_code: int = 200, **context: object
) -> HTMLResponse:
    """A page; forms on it get the session's CSRF token as ``csrf``."""
    visitor = getattr(request.state, "visitor", None)
    if visitor is not None:
        secret = request.app.state.services.secret
        context.setdefault("csrf", csrf_token(secret, visitor.session_id))
    context.setdefault("person", getattr(request.state, "person", None))
    context.setdefault("request", request)  # as Starlette's TemplateResponse gives it
    # The template rendered straight into a page: Starlette's TemplateResponse adds a
    # response class, context processors and a debug message per page (a third of what
    # a phone's page spent in its template, issue 32).
    html = request.app.state.templates.get_template(template).render(context)
    return HTMLResponse(html, status_code=status_code)
