"""A live poll, written on the app contract alone (docs/apps.md).

An instructor asks the room a question from the dashboard (the app's panel and API,
routes.py); the wall shows one bar per choice with a code beside it (its layer,
static/poll.js); a phone that scans a choice's code votes once and sees the counts,
which every tile follows as votes come in. The questions are the app's own table;
the votes, a round of the shared quiz engine per poll (polls.py).
"""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, Response

from poll_app.polls import APP, PollState, closed, columns, question_of, quiz_of, vote
from poll_app.routes import router, show_counts
from wall_client.layout import Wall
from webapp.apps.hooks import Export, Scan, WallApp, static_url
from webapp.classes.roll import ClassSession
from webapp.core.threads import run_blocking
from webapp.engine.wall_state import AppState, WallState
from webapp.tags.registry import TagSpec, anchored_code_side_mm
from webapp.web.context import AppContext
from webapp.web.templating import render

FOLDER = Path(__file__).parent


class PollApp(WallApp):
    name: str = APP
    state: type[AppState] | None = PollState
    layers: tuple[str, ...] = (f"{static_url(APP)}/poll.js",)
    templates: Path | None = FOLDER / "templates"
    static: Path | None = FOLDER / "static"
    migrations: Path | None = FOLDER / "migrations"

    def declare_tags(self, context: AppContext, wall: Wall, state: WallState) -> list[TagSpec]:
        """A code per choice of the poll on the wall, under its bar: new codes for each
        poll, so a photo of last week's code cannot vote in this one."""
        number = PollState.of(state).round
        if state.app != APP or number is None:
            return []
        question = question_of(context.db, wall.id, number)
        if question is None:
            return []
        below = wall.stage.bottom - anchored_code_side_mm(context.base_url, wall)
        return [
            TagSpec(
                name=f"poll:{number}:{index}",
                label=choice,
                app=APP,
                action="vote",
                params={"round": number, "choice": choice},
                anchor=((left + right) / 2, below),
            )
            for index, (choice, (left, right)) in enumerate(
                zip(question.choices, columns(wall, len(question.choices)), strict=True)
            )
        ]

    async def on_scan(self, scan: Scan) -> Response:
        """The phone votes for the choice it scanned, once, and sees the counts."""
        page = await ballot_page(scan, scan.tag.params["choice"])
        return page if page is not None else await super().on_scan(scan)

    async def on_retired_scan(self, scan: Scan, problem: str) -> Response | None:
        """A code of an earlier poll (or one switched off): the poll's counts, no vote."""
        return await ballot_page(scan, None)

    def begin_class(
        self, context: AppContext, wall: Wall, state: WallState, mode: str | None
    ) -> WallState:
        """A class starts with no poll on the wall: the last one closes and leaves."""
        self.end_class(context, wall, state)  # closes it
        return PollState().put(state)

    def end_class(self, context: AppContext, wall: Wall, state: WallState) -> WallState:
        """The poll running closes with the class; the wall keeps its counts."""
        number = PollState.of(state).round
        if number is None:
            return state
        quiz_of(context.db).close_round(wall.id, number, f"app:{APP}")
        return closed(number)(state)

    def class_exports(self, context: AppContext, wall: Wall, held: ClassSession) -> list[Export]:
        """The votes of each poll the class asked, one CSV each."""
        exports = []
        for number in quiz_of(context.db).rounds_during(wall.id, held):
            question = question_of(context.db, wall.id, number)
            label = question.text if question is not None else f"Poll {number}"
            url = f"/api/apps/poll/walls/{wall.id}/polls/{number}/answers.csv"
            exports.append(Export(f"{label} (CSV)", url))
        return exports

    def dashboard_panel(self, wall: Wall) -> str | None:
        return "poll/panel.html"

    def router(self) -> APIRouter | None:
        return router


async def ballot_page(scan: Scan, choice: str | None) -> Response | None:
    """The phone's vote for ``choice`` (None: none) and the poll's counts (None: the
    poll is gone)."""
    context, wall, number = scan.context, scan.wall, scan.tag.params["round"]
    ballot = await run_blocking(vote, context.db, wall.id, number, scan.visitor.id, choice)
    if ballot is None:
        return None
    if ballot.refused is None:
        await show_counts(context, wall, number, ballot.question)
    return render(scan.request, "poll/vote.html", wall=wall, ballot=ballot)
