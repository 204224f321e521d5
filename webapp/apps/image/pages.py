"""The image app's phone pages and the reads they need: a hotspot (its title and text
for the phone's user group, or its question while a round runs) and what it publishes.
The answer to its question is stored in ``routes/phones``; these pages write nothing.

A question is a secret while its round runs: the page then shows the question and the
form, never the hotspot's title, text or accepted answers (any of which may give the
answer away), until the round's rule says the student may see them
(``Round.names_shown``); instructors see them at once. The public screen gets what
the page shows, never more.
"""

from __future__ import annotations

from dataclasses import dataclass

from fastapi import HTTPException, Request, Response, status
from markupsafe import Markup

from wall_client.layout import Wall
from webapp.apps.image.hotspots import Hotspot, hotspots
from webapp.apps.image.library import image_library
from webapp.apps.image.questions import (
    numbers,
    quiz_of,
    reveals_answers,
    round_on_wall,
)
from webapp.core.markdown import markdown_html
from webapp.core.roles import UserGroup
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import read_state
from webapp.people.person import Person
from webapp.publishing.publication import Block, Publication
from webapp.quiz.engine import Progress, Round
from webapp.web.context import AppContext
from webapp.web.templating import render

GROUP_LABELS: dict[UserGroup, str] = {
    "k5": "K-5",
    "undergraduate": "Undergraduate",
    "medical": "Medical",
    "research": "Research",
}


@dataclass(frozen=True)
class Spot:
    """A scanned hotspot as its page needs it, read in one go."""

    image_id: str
    spot: Hotspot
    spots: list[Hotspot]
    round: Round | None  # the round on the wall
    number: int | None  # the question's number in it (None: no question, or no round)
    stale: bool  # the code is of an earlier round than the wall's
    progress: Progress | None  # the visitor's answers in the round

    @property
    def asking(self) -> bool:
        """The form is shown: a question of the running round, by a code of that round."""
        return self.number is not None and self.round is not None and self.round.open

    def secret(self, person: Person) -> bool:
        """Whether the hotspot's title, text and answers are hidden from ``person``."""
        if not self.spot.question or self.round is None or reveals_answers(person):
            return False
        finished = self.progress is not None and self.progress.finished
        return not self.round.names_shown(finished)


def spot_of(context: AppContext, wall: Wall, tag: TagRecord, person: Person) -> Spot:
    """What ``tag`` marks and where the visitor stands (in a worker thread)."""
    image_id = str(tag.params.get("image", ""))
    try:
        spots = hotspots(image_library(context).store(context.settings), image_id)
    except KeyError:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That image is no longer stored.") from None
    spot = next((s for s in spots if s.id == tag.params.get("hotspot")), None)
    if spot is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That hotspot was removed.")
    _, state = read_state(context.db, wall.id)
    quiz_round = round_on_wall(context, wall.id, state)
    number, progress, stale = None, None, False
    if quiz_round is not None and spot.question:
        stale = tag.params.get("round") != quiz_round.number
        number = None if stale else numbers(quiz_round, image_id, spots).get(spot.id)
        progress = quiz_of(context).progress(
            wall.id, quiz_round.number, person.visitor.id, image_id
        )
    return Spot(image_id, spot, spots, quiz_round, number, stale, progress)


def text_html(spot: Hotspot, person: Person) -> tuple[str | None, Markup | None]:
    """The hotspot's text for the visitor's group (whose group wrote it, if another),
    rendered safely; information class 1 reads its first paragraph."""
    found = spot.text_for(person.user_group)
    if found is None:
        return None, None
    reader, text = found
    if person.info_class <= 1:
        text = text.split("\n\n")[0]
    return (GROUP_LABELS[reader] if reader != person.user_group else None), markdown_html(text)


async def hotspot_page(
    request: Request,
    context: AppContext,
    wall: Wall,
    tag: TagRecord,
    person: Person,
    problem: str | None = None,
    status_code: int = status.HTTP_200_OK,
) -> Response:
    seen = await run_blocking(spot_of, context, wall, tag, person)
    secret = seen.secret(person)
    written_for, text = (None, None) if secret else text_html(seen.spot, person)
    mine = seen.progress.answers.get(seen.spot.id) if seen.progress else None
    return render(
        request,
        "image/hotspot.html",
        status_code=status_code,
        wall=wall,
        tag=tag,
        seen=seen,
        spot=seen.spot,
        secret=secret,
        text=text,
        written_for=written_for,
        previous=mine.text if mine else "",
        right=None if secret or mine is None else mine.correct,
        finished=bool(seen.progress and seen.progress.finished),
        problem=problem,
    )


async def publication(
    context: AppContext, wall: Wall, tag: TagRecord, person: Person
) -> Publication | None:
    """The hotspot's title and text as the phone shows them; nothing while its question
    is a secret (the public screen is seen by every student)."""
    seen = await run_blocking(spot_of, context, wall, tag, person)
    running = seen.round is not None and seen.round.open
    if seen.secret(person) or (seen.spot.question and running):
        return None
    found = seen.spot.text_for(person.user_group)
    blocks = [Block(kind="markdown", text=found[1][:8_000])] if found else []
    return Publication(title=seen.spot.title, blocks=blocks)
