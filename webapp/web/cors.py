"""Answers a page of any site may read: what tagwall serves other programs to draw, such
as the census map's KML for Google Earth, which CesiumJS loads from its own page's site,
and the images that KML names.

Only for answers that are the same for everyone and read no cookie: to a page of
another site, ``Access-Control-Allow-Origin: *`` shows only what it asked for without
credentials (a browser never reads an answer under ``*`` to a request that carried
them), so the page reads what its user could fetch with no session at all.
"""

from __future__ import annotations

from collections.abc import Collection

from fastapi.routing import APIRoute
from starlette.datastructures import Headers, MutableHeaders
from starlette.responses import Response
from starlette.types import Message, Receive, Scope, Send

PREFLIGHT_MAX_AGE_S = 86_400  # browsers keep a preflight's answer this long at most


class AnyOriginRoute(APIRoute):
    """A route whose answers, its errors included, a page of any site may read; it
    answers a CORS preflight (the OPTIONS a browser sends first when a page's request
    carries headers of its own) instead of refusing the method."""

    async def handle(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["method"] == "OPTIONS":
            await preflight(Headers(scope=scope), self.methods or ())(scope, receive, send)
            return

        async def send_readable(message: Message) -> None:
            if message["type"] == "http.response.start":
                MutableHeaders(scope=message)["Access-Control-Allow-Origin"] = "*"
            await send(message)

        await super().handle(scope, receive, send_readable)


def preflight(request: Headers, methods: Collection[str]) -> Response:
    """What a browser must hear before a page of another site may send its request:
    any site, the route's methods, the headers it asked to send."""
    headers = {
        "Access-Control-Allow-Origin": "*",
        "Access-Control-Allow-Methods": ", ".join(sorted(methods)),
        "Access-Control-Max-Age": str(PREFLIGHT_MAX_AGE_S),
    }
    if asked := request.get("access-control-request-headers"):
        headers["Access-Control-Allow-Headers"] = asked
    return Response(status_code=204, headers=headers)
