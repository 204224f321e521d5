"""What every app's quiz routes share: a change of rounds answered as HTTP, and a
round's answers as a spreadsheet download named by its wall, class, round and day."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from fastapi import HTTPException, Response, status

from wall_client.layout import Wall
from webapp.classes.roll import class_at
from webapp.core.threads import run_blocking
from webapp.quiz.engine import Quiz, QuizError, Round
from webapp.web.downloads import attachment


async def round_step(step: Callable[..., Round], *args: object) -> Round:
    """Run a change of rounds in a worker thread; what cannot be done now is a 409."""
    try:
        return await run_blocking(step, *args)
    except QuizError as error:
        raise HTTPException(status.HTTP_409_CONFLICT, str(error)) from error


async def answers_download(
    quiz: Quiz,
    wall: Wall,
    quiz_round: Round | None,
    about: Mapping[tuple[str, str], Sequence[str]] | None = None,
) -> Response:
    """Every answer of ``quiz_round`` as CSV (404 when there is no such round; ``about``
    as :meth:`Quiz.export_csv` takes it), in a file named by the wall, the round's
    class, the round and its local day."""
    if quiz_round is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "There is no such round.")
    body = await run_blocking(quiz.export_csv, wall.id, quiz_round.number, wall.time_zone, about)
    held = await run_blocking(class_at, quiz.db, wall.id, quiz_round.started_at)
    day = wall.local_time(quiz_round.started_at).date().isoformat()
    parts = [wall.id, held.title if held is not None else "", f"round-{quiz_round.number}", day]
    return Response(
        body,
        media_type="text/csv; charset=utf-8",
        headers={"Content-Disposition": attachment(parts, ".csv")},
    )
