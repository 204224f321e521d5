"""What the API answers when it cannot do what was asked, and the meaning of each error
status, for every route, the core's and the apps'."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel


class Problem(BaseModel):
    """What the API answers when it cannot do what was asked: a sentence for a person."""

    detail: str


ERROR_MEANINGS = {
    400: "The request body could not be read (not JSON, or not UTF-8).",
    401: "Not signed in as an instructor, or a bearer token that is not the operator token.",
    403: "Not allowed: a missing or wrong tile token or CSRF header, or a role that may not.",
    404: "No such wall, tile or other thing named in the path or query.",
    409: "Not possible in the wall's present state (another app is on the wall, say).",
    502: "A server this one asks on the caller's behalf (a site's own) failed or refused.",
    503: "The database (or, with several server processes, Redis) does not answer; try again.",
    504: "A server this one asks on the caller's behalf (a site's own) did not answer in time.",
}


def errors(*codes: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses`` for error statuses an operation answers with."""
    return {code: {"model": Problem, "description": ERROR_MEANINGS[code]} for code in codes}
