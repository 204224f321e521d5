"""The brain atlas's phone pages and the reads they need: a pin (the quiz question or
the tutor page), the quiz's progress and results, the instructor's answer, the user
groups. What phones do (an answer, finishing, joining a group) is in
``routes/phones``; these pages write nothing.

Every page that could name a region checks, on the server and for this visitor, that
it may: the quiz form never carries the name, the answer page needs an instructor,
results show names by the round's rule (``Round.names_shown``), tutor pages need
tutor mode and no running round. A pin's code belongs to one round: scanned after
the next round started, it says so instead of opening anything.
"""

from __future__ import annotations

from fastapi import HTTPException, Request, Response, status

from wall_client.layout import Wall
from webapp.apps.brain_atlas.atlas import Atlas, Pin, RoundChanged, RoundGuide, set_of_pin
from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.apps.brain_atlas.rules import (
    APP,
    GROUP_LABELS,
    mode_of,
    quiz_of,
    reveals_answers,
    set_on_wall,
)
from webapp.core.markdown import markdown_html
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import WallState
from webapp.people.person import Person
from webapp.quiz.engine import Progress, Round
from webapp.web.context import AppContext
from webapp.web.templating import render

SUMMARY_PARAGRAPHS = 2  # of a tutor text, on the phone; the public screen shows it all


def round_changed_page(
    request: Request, wall: Wall, tag: TagRecord, status_code: int = status.HTTP_200_OK
) -> Response:
    """The friendly answer to a code of an earlier round."""
    return render(
        request, "brain/new_round.html", status_code=status_code, wall=wall, tag_set=set_of_pin(tag)
    )


async def tutor_subject(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord
) -> Region | None:
    """The region a pin shows in tutor mode; None while a quiz round runs (then no
    pin may be named anywhere) or for an earlier round's code."""
    try:
        pin = await context.db.read(app.pin, context, wall, tag)
    except RoundChanged:
        return None
    if pin.state.app != APP or mode_of(pin.state) != "tutor" or pin.round.open:
        return None
    return pin.region


async def tutor_region(app: Atlas, context: AppContext, wall: Wall, tag: TagRecord) -> Region:
    """The region of a tutor page; 409 while a quiz round runs."""
    found = await tutor_subject(app, context, wall, tag)
    if found is None:
        raise HTTPException(
            status.HTTP_409_CONFLICT,
            "A quiz round is running: the tutor pages open when the instructor closes it.",
        )
    return found


def wording(tag_set: TagSetName) -> str:
    """Which words the quiz pages use: children's for the K-5 pins."""
    return "k5" if tag_set == "k5" else "full"


# --- pins --------------------------------------------------------------------------


async def pin_page(
    app: Atlas, request: Request, context: AppContext, wall: Wall, tag: TagRecord, person: Person
) -> Response:
    """A scanned pin: the quiz question, the region's tutor page, or word that a new
    round has started."""
    try:
        pin, now = await context.db.read(pin_and_progress, app, context, wall, tag, person)
    except RoundChanged:
        return round_changed_page(request, wall, tag)
    if mode_of(pin.state) == "tutor":
        return await tutor_page(app, request, context, wall, tag, person)
    return question_page(app, request, wall, pin, now, person)


def pin_and_progress(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord, person: Person
) -> tuple[Pin, Progress]:
    """The pin and how far the visitor is in its round (one ``db.read``)."""
    pin = app.pin(context, wall, tag)
    return pin, quiz_of(context).progress(wall.id, pin.round.number, person.visitor.id, pin.tag_set)


def question_page(
    app: Atlas,
    request: Request,
    wall: Wall,
    pin: Pin,
    now: Progress,
    person: Person,
    problem: str | None = None,
    status_code: int = 200,
) -> Response:
    mine = now.answers.get(pin.region.id)
    shown = pin.round.names_shown(now.finished)
    return render(
        request,
        "brain/question.html",
        status_code=status_code,
        wall=wall,
        tag=pin.tag,
        number=pin.number,
        tag_set=pin.tag_set,
        words=wording(pin.tag_set),
        question=pin.question,
        round_open=pin.round.open,
        previous=mine.text if mine else "",
        right=bool(mine and mine.correct) if shown else None,
        name=pin.region.name if shown else None,
        finished=now.finished,
        answered=len(now.answers),
        total=len(app.regions(pin.tag_set)),
        may_reveal=reveals_answers(person) and pin.round.open,
        problem=problem,
    )


async def revealed(
    app: Atlas, request: Request, context: AppContext, wall: Wall, person: Person, tag: TagRecord
) -> Response:
    """The correct name of a pin, for instructors only (checked here, for this
    session: a URL copied from an instructor's phone gives a student nothing)."""
    if not reveals_answers(person):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "Only instructors see answers early: students see them when the round closes.",
        )
    try:
        pin, guide = await run_blocking(pin_and_guide, app, context, wall, tag)
    except RoundChanged as changed:
        return round_changed_page(request, wall, changed.tag, status.HTTP_409_CONFLICT)
    return render(
        request,
        "brain/revealed.html",
        wall=wall,
        number=pin.number,
        tag_set=pin.tag_set,
        region=pin.region,
        views=guide.views.get(pin.number, []),
    )


def pin_and_guide(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord
) -> tuple[Pin, RoundGuide]:
    """A pin and its round's guide (in a worker thread)."""
    pin = app.pin(context, wall, tag)
    return pin, app.guide(context, wall, pin.round, pin.tag_set, pin.state)


# --- the quiz as a whole -------------------------------------------------------------


async def progress_page(
    app: Atlas,
    request: Request,
    context: AppContext,
    wall: Wall,
    person: Person,
    tag_set: TagSetName,
    problem: str | None = None,
) -> Response:
    """How far the visitor is and where the open pins are; the correct names when
    the round's rule says so."""
    facts = await context.db.read(progress_facts, app, context, wall, person, tag_set)
    if facts is None:
        return render(request, "brain/no_round.html", wall=wall)
    state, quiz_round, now, guide = facts
    shown = quiz_round.names_shown(now.finished)
    numbered = app.pins(quiz_round, tag_set)
    rows = [
        _row(now, number, region, guide.codes.get(number), guide.views.get(number, []), shown)
        for number, region in sorted(numbered.items())
    ]
    open_pins = [row["number"] for row in rows if row["answer"] is None]
    by_view: dict[str, list[object]] = {}
    for row in rows:
        if row["answer"] is None:
            for view in row["views"]:  # type: ignore[attr-defined]
                by_view.setdefault(view, []).append(row["number"])
    showing_set = state.app == APP and set_on_wall(state) == tag_set
    return render(
        request,
        "brain/progress.html",
        wall=wall,
        tag_set=tag_set,
        words=wording(tag_set),
        round=quiz_round,
        rows=rows,
        shown=shown,
        finished=now.finished,
        complete=now.complete(list(numbered.values())),
        answered=len(now.answers),
        right=sum(1 for a in now.answers.values() if a.correct),
        total=len(numbered),
        open_now=[n for n in open_pins if showing_set and n in guide.on_wall],
        by_view=by_view,
        problem=problem,
    )


def progress_facts(
    app: Atlas, context: AppContext, wall: Wall, person: Person, tag_set: TagSetName
) -> tuple[WallState, Round, Progress, RoundGuide] | None:
    """What the progress page shows, read in one ``db.read``; None before the
    quiz's first round."""
    state, quiz_round = app.current_round(context, wall)
    if quiz_round is None:
        return None
    now = quiz_of(context).progress(wall.id, quiz_round.number, person.visitor.id, tag_set)
    return state, quiz_round, now, app.guide(context, wall, quiz_round, tag_set, state)


def _row(
    now: Progress, number: int, region: Region, code: str | None, views: list[str], shown: bool
) -> dict[str, object]:
    """One pin on the progress page: the visitor's own answer and the views whose
    codes lead to it; the correct name and whether they were right only when the
    round's rule shows names."""
    mine = now.answers.get(region.id)
    row: dict[str, object] = {
        "number": number,
        "code": code,
        "answer": mine.text if mine else None,
        "views": views,
    }
    if shown:
        row["name"] = region.name
        row["correct"] = bool(mine and mine.correct)
    return row


# --- tutor ---------------------------------------------------------------------------


async def tutor_page(
    app: Atlas, request: Request, context: AppContext, wall: Wall, tag: TagRecord, person: Person
) -> Response:
    """The region's page for the visitor's group: a summary here, the whole text on
    the public screen when published."""
    region = await tutor_region(app, context, wall, tag)
    found = app.tutor_text(region, person.user_group)
    if found is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "This region has no page for you yet.")
    audience, text = found
    paragraphs = text.text.strip().split("\n\n")
    return render(
        request,
        "brain/tutor.html",
        wall=wall,
        tag=tag,
        region=region,
        group=GROUP_LABELS[audience],
        summary=markdown_html("\n\n".join(paragraphs[:SUMMARY_PARAGRAPHS])),
        more=len(paragraphs) > SUMMARY_PARAGRAPHS,
        references=[app.content.references[r] for r in text.references],
        research=audience == "research" and app.has_research(region),
    )


# --- the user groups -----------------------------------------------------------------


def groups_page(request: Request, wall: Wall, person: Person) -> Response:
    """Every user group as a button: the phone's own choice."""
    return render(
        request, "brain/groups.html", wall=wall, groups=GROUP_LABELS, current=person.user_group
    )
