"""The brain atlas's phone pages: a pin (the quiz question or the tutor page), the
quiz's progress and results, the instructor's answer, the user groups.

Every page that could name a region checks, on the server and for this visitor, that
it may: the quiz form never carries the name, the answer page needs an instructor,
results show names by the round's rule (``Round.names_shown``), tutor pages need
tutor mode and no running round. A pin's code belongs to one round: scanned after
the next round started, it says so instead of opening anything.
"""

from __future__ import annotations

from dataclasses import dataclass

from fastapi import HTTPException, Request, Response, status
from fastapi.responses import RedirectResponse

from tag_service.codes import normalize_code
from wall_client.layout import Wall
from webapp.apps.brain_atlas.atlas import Atlas, RoundGuide
from webapp.apps.brain_atlas.audience import audience_switches, claim_audience_switch
from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.apps.brain_atlas.rules import (
    APP,
    GROUP_LABELS,
    TAG_SETS,
    mode_of,
    pin_question,
    quiz_of,
    reveals_answers,
    set_of_group,
    set_on_wall,
)
from webapp.apps.hooks import Scan
from webapp.core.markdown import markdown_html
from webapp.core.roles import USER_GROUPS, UserGroup
from webapp.core.threads import run_blocking
from webapp.database.models import TagRecord
from webapp.engine.wall_state import WallState, read_state
from webapp.people.person import Person, remember_person, update_profile
from webapp.people.visitors import Visitor
from webapp.quiz.engine import Progress, Question, QuizError, Round
from webapp.web.context import AppContext
from webapp.web.templating import render

SUMMARY_PARAGRAPHS = 2  # of a tutor text, on the phone; the public screen shows it all


# --- looking things up -----------------------------------------------------------------


@dataclass(frozen=True)
class Pin:
    """A pin as the wall shows it now: its set, number and region in the round."""

    tag: TagRecord
    tag_set: TagSetName
    number: int
    region: Region
    round: Round
    state: WallState

    @property
    def question(self) -> Question:
        return pin_question(self.region, self.tag_set)


class RoundChanged(Exception):
    """The pin's code belongs to an earlier round (or the quiz has none yet)."""

    def __init__(self, tag: TagRecord) -> None:
        super().__init__(tag.code)
        self.tag = tag


async def tag_of(context: AppContext, wall: Wall, code: str) -> TagRecord:
    """A brain pin of this wall by its code (switched off ones too: a pin the wall no
    longer shows may still be answered); 404 otherwise. From the scan path's cache of
    codes: every answer of a room looks its pin up."""
    normal = normalize_code(code)
    tag = (await context.codes.resolve(normal)).tag if normal else None
    if tag is None or tag.wall_id != wall.id or tag.app != APP or tag.action != "pin":
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That is not a pin of this wall's brain.")
    return tag


def current_round(app: Atlas, context: AppContext, wall: Wall) -> tuple[WallState, Round | None]:
    """The wall's state and the quiz round it names (synchronous: a page reads all it
    needs in one :meth:`~webapp.database.connection.Database.read`)."""
    _, state = read_state(context.db, wall.id)
    return state, app.round_on_wall(context, wall.id, state)


async def round_now(app: Atlas, context: AppContext, wall: Wall) -> tuple[WallState, Round | None]:
    return await context.db.read(current_round, app, context, wall)


def pin_of(app: Atlas, context: AppContext, wall: Wall, tag: TagRecord) -> Pin:
    """What ``tag`` marks in the round on the wall; RoundChanged for an old round's
    (synchronous, like :func:`current_round`)."""
    state, quiz_round = current_round(app, context, wall)
    if quiz_round is None or tag.params.get("round") != quiz_round.number:
        raise RoundChanged(tag)
    tag_set: TagSetName = "k5" if tag.params.get("set") == "k5" else "full"
    number = int(tag.params.get("pin", 0))
    region = app.pins(quiz_round, tag_set).get(number)
    if region is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "That pin is no longer in the atlas.")
    return Pin(tag, tag_set, number, region, quiz_round, state)


def round_changed_page(
    request: Request, wall: Wall, tag: TagRecord, status_code: int = status.HTTP_200_OK
) -> Response:
    """The friendly answer to a code of an earlier round."""
    tag_set: TagSetName = "k5" if tag.params.get("set") == "k5" else "full"
    return render(
        request, "brain/new_round.html", status_code=status_code, wall=wall, tag_set=tag_set
    )


async def tutor_subject(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord
) -> Region | None:
    """The region a pin shows in tutor mode; None while a quiz round runs (then no
    pin may be named anywhere) or for an earlier round's code."""
    try:
        pin = await context.db.read(pin_of, app, context, wall, tag)
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
    pin = pin_of(app, context, wall, tag)
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


async def answer(
    app: Atlas,
    request: Request,
    context: AppContext,
    wall: Wall,
    person: Person,
    code: str,
    text: str,
) -> Response:
    """Store the visitor's answer, judged now, and go on to their progress."""
    tag = await tag_of(context, wall, code)
    try:
        pin, refused = await run_blocking(store_answer, app, context, wall, tag, person, text)
    except RoundChanged as changed:
        return round_changed_page(request, wall, changed.tag, status.HTTP_409_CONFLICT)
    if refused is not None:
        now, problem = refused
        return question_page(
            app, request, wall, pin, now, person, problem, status.HTTP_422_UNPROCESSABLE_CONTENT
        )
    return progress_redirect(wall, pin.tag_set)


def store_answer(
    app: Atlas, context: AppContext, wall: Wall, tag: TagRecord, person: Person, text: str
) -> tuple[Pin, tuple[Progress, str] | None]:
    """Judge and store an answer to the pin ``tag`` (in a worker thread); when the
    quiz refuses it, the visitor's progress and why. The pin's reads share one connection
    (as a page's do in :meth:`~webapp.database.connection.Database.read`); the answer is
    written on another, in a transaction of its own."""
    with context.db.reading():
        pin = pin_of(app, context, wall, tag)
    correct = app.answer_key(pin.tag_set).judge(pin.region.id, text[:1_000])
    try:
        if mode_of(pin.state) != "quiz":
            raise QuizError("The wall is in tutor mode: answers are taken in quiz mode only.")
        quiz_of(context).record_answer(
            wall.id,
            pin.round.number,
            person.visitor.id,
            pin.tag_set,
            pin.question,
            text,
            correct,
        )
    except QuizError as error:
        now = quiz_of(context).progress(wall.id, pin.round.number, person.visitor.id, pin.tag_set)
        return pin, (now, str(error))
    return pin, None


def progress_redirect(wall: Wall, tag_set: TagSetName) -> Response:
    return RedirectResponse(f"/apps/brain/{wall.id}/quiz/{tag_set}", status.HTTP_303_SEE_OTHER)


async def revealed(
    app: Atlas, request: Request, context: AppContext, wall: Wall, person: Person, code: str
) -> Response:
    """The correct name of a pin, for instructors only (checked here, for this
    session: a URL copied from an instructor's phone gives a student nothing)."""
    if not reveals_answers(person):
        raise HTTPException(
            status.HTTP_403_FORBIDDEN,
            "Only instructors see answers early: students see them when the round closes.",
        )
    tag = await tag_of(context, wall, code)
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
    pin = pin_of(app, context, wall, tag)
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
    state, quiz_round = current_round(app, context, wall)
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


async def finished(
    app: Atlas,
    request: Request,
    context: AppContext,
    wall: Wall,
    person: Person,
    tag_set: TagSetName,
) -> Response:
    _, quiz_round = await round_now(app, context, wall)
    try:
        if quiz_round is None:
            raise QuizError("The quiz has not started yet.")
        await run_blocking(
            quiz_of(context).finish,
            wall.id,
            quiz_round.number,
            person.visitor.id,
            tag_set,
            app.regions(tag_set),
        )
    except QuizError as error:
        return await progress_page(app, request, context, wall, person, tag_set, str(error))
    return progress_redirect(wall, tag_set)


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


async def choose_group(app: Atlas, scan: Scan) -> Response:
    """A scanned group code on the menu screen: the phone joins that group, and the
    wall follows only where the instructor lets the audience switch it."""
    person = await scan.person()
    group = str(scan.tag.params.get("group", ""))
    return await join_group(
        app, scan.request, scan.context, scan.wall, person, group, True, scan.address
    )


async def join_group(
    app: Atlas,
    request: Request,
    context: AppContext,
    wall: Wall,
    person: Person,
    group: str,
    from_menu: bool = False,
    address: str = "",
) -> Response:
    """The phone joins ``group`` (its pages speak to that group from now on). Scanned
    off the menu screen, the wall may follow too (:func:`audience_switch`)."""
    if group not in USER_GROUPS:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"There is no user group {group!r}.")
    chosen: UserGroup = group
    updated = await run_blocking(
        update_profile,
        context.db,
        person,
        context.settings,
        user_group=chosen,
        info_class=person.info_class,
        display_name=person.display_name,
    )
    remember_person(request, updated)
    wanted = set_of_group(chosen)
    outcome = (
        await audience_switch(app, context, wall, wanted, person.visitor, address)
        if from_menu
        else None
    )
    state = await context.state(wall)
    return render(
        request,
        "brain/group.html",
        wall=wall,
        group=GROUP_LABELS[chosen],
        wanted=wanted,
        on_wall=set_on_wall(state) if state.app == APP else None,
        outcome=outcome,
        pins=len(app.regions(wanted)),
    )


async def audience_switch(
    app: Atlas,
    context: AppContext,
    wall: Wall,
    wanted: TagSetName,
    visitor: Visitor,
    address: str,
) -> str:
    """Switch the wall to ``wanted``'s pins for an audience scan, if allowed now; says
    what happened: ``same``, ``switched``, ``instructor`` (the instructor keeps the
    wall's pins), ``quiz`` (a round is running) or ``wait`` (the cooldown, or the
    phone's own limits on changing the wall: the phone still joins its group)."""
    state, quiz_round = await round_now(app, context, wall)
    if state.app != APP or set_on_wall(state) == wanted:
        return "same"
    if not await run_blocking(audience_switches, context.db, wall.id):
        return "instructor"
    if mode_of(state) == "quiz" and quiz_round is not None and quiz_round.open:
        return "quiz"
    if await context.action_allowed("group", visitor, address, wall.id) is not None:
        return "wait"
    cooldown = context.settings.brain_group_switch_cooldown
    if not await run_blocking(claim_audience_switch, context.db, wall.id, cooldown):
        return "wait"
    await show_set(context, wall, wanted)
    return "switched"


def groups_page(request: Request, wall: Wall, person: Person) -> Response:
    """Every user group as a button: the phone's own choice."""
    return render(
        request, "brain/groups.html", wall=wall, groups=GROUP_LABELS, current=person.user_group
    )


async def show_set(context: AppContext, wall: Wall, tag_set: TagSetName) -> None:
    """Put a set's pins on the wall (every tile at once)."""

    def switch(state: WallState) -> WallState:
        if state.app != APP:
            return state
        return state.model_copy(update={"tag_set": TAG_SETS[tag_set]})

    await context.change_wall(wall, switch)
