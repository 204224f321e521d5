"""What phones ask for of the image app and what they do: a hotspot's page again, and
the answer to its question, judged by the hotspot's accepted answers and stored by the
quiz engine. The page is ``pages``'."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Form, HTTPException, Request, Response, status
from fastapi.responses import RedirectResponse

from tag_service.codes import normalize_code
from wall_client.layout import Wall
from webapp.apps.image import pages
from webapp.apps.image.questions import judge, question_of, quiz_of
from webapp.apps.image.state import APP
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.people.person import Person
from webapp.quiz.engine import QuizError
from webapp.web.context import AppContext
from webapp.web.deps import CsrfDep, PhoneDep

router = APIRouter(tags=["image"])


async def tag_of(context: AppContext, wall: Wall, code: str) -> TagRecord:
    """A hotspot code of this wall (switched off ones too: a question of the running
    round may still be answered when the view moved on); 404 otherwise."""
    normal = normalize_code(code)
    tag = (await context.codes.resolve(normal)).tag if normal else None
    if tag is None or tag.wall_id != wall.id or tag.app != APP or tag.action != "hotspot":
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That is not a hotspot of this wall.")
    return tag


@router.get("/apps/image/{wall_id}/hotspots/{code}", include_in_schema=False)
async def hotspot_page(request: Request, phone: PhoneDep, code: str) -> Response:
    """A hotspot's page again (after an answer), without counting a scan."""
    tag = await tag_of(phone.context, phone.wall, code)
    return await pages.hotspot_page(request, phone.context, phone.wall, tag, phone.person)


@router.post(
    "/apps/image/{wall_id}/hotspots/{code}/answer",
    include_in_schema=False,
    dependencies=[CsrfDep],
)
async def answer(
    request: Request, phone: PhoneDep, code: str, answer: Annotated[str, Form()] = ""
) -> Response:
    """Judge and store the visitor's answer, then show the hotspot's page again."""
    context, wall, person = phone.context, phone.wall, phone.person
    tag = await tag_of(context, wall, code)
    problem = await run_blocking(store_answer, context, wall, tag, person, answer)
    if problem is not None:
        return await pages.hotspot_page(
            request, context, wall, tag, person, problem, status.HTTP_422_UNPROCESSABLE_CONTENT
        )
    return RedirectResponse(f"/apps/image/{wall.id}/hotspots/{tag.code}", status.HTTP_303_SEE_OTHER)


def store_answer(
    context: AppContext, wall: Wall, tag: TagRecord, person: Person, text: str
) -> str | None:
    """Store an answer to the hotspot ``tag`` (in a worker thread); why not, if refused."""
    seen = pages.spot_of(context, wall, tag, person)
    if seen.stale:
        return "This code is from an earlier round: scan the hotspot's code on the wall now."
    if seen.round is None or seen.number is None:
        return "This hotspot asks nothing now."
    try:
        quiz_of(context).record_answer(
            wall.id,
            seen.round.number,
            person.visitor.id,
            seen.image_id,
            question_of(seen.spot),
            text,
            judge(seen.spot, seen.spots, text[:1_000]),
        )
    except QuizError as error:
        return str(error)
    return None
