"""The image app's quiz: its hotspots' questions in the shared quiz engine (app
``image``), one set per image, numbered afresh in every round, with new codes."""

from __future__ import annotations

from webapp.apps.image.hotspots import Hotspot, hotspots
from webapp.apps.image.state import APP, ImageState
from webapp.apps.image.store import ImageStore
from webapp.engine.wall_state import WallState
from webapp.people.person import Person
from webapp.quiz.engine import Columns, Question, Quiz, Round, new_order
from webapp.quiz.matching import matches
from webapp.web.context import AppContext

COLUMNS = Columns(set="image", item="hotspot", about=("title", "question"))
"""The answers CSV's columns: each answer's image and hotspot, named by the hotspot's
title and question, not only by ids."""


def quiz_of(context: AppContext) -> Quiz:
    return Quiz(context.db, APP, COLUMNS)


def asked(spots: list[Hotspot]) -> list[Hotspot]:
    """The hotspots with a question: the items of the image's set."""
    return [spot for spot in spots if spot.question]


def question_of(spot: Hotspot) -> Question:
    """A hotspot's question: typed, judged by :func:`judge`."""
    return Question(spot.id, spot.question or "")


def described(store: ImageStore, quiz_round: Round) -> dict[tuple[str, str], tuple[str, str]]:
    """Each question of the round's images as its CSV rows name it: the hotspot's title
    and question as they are now (none for an image since removed)."""
    about: dict[tuple[str, str], tuple[str, str]] = {}
    for image_id in quiz_round.orders:
        try:
            spots = hotspots(store, image_id)
        except KeyError:
            continue
        about |= {(image_id, spot.id): (spot.title, spot.question or "") for spot in spots}
    return about


def fresh_orders(image_id: str, spots: list[Hotspot]) -> dict[str, list[str]]:
    """A new round's numbering: the image's questions in a fresh random order (the set
    is named by the image, so a round keeps the numbers of each image it showed)."""
    return {image_id: new_order(asked(spots))}


def numbers(quiz_round: Round, image_id: str, spots: list[Hotspot]) -> dict[str, int]:
    """Hotspot id -> its question's number in the round."""
    return {spot.id: n for n, spot in quiz_round.numbered(image_id, asked(spots)).items()}


def round_on_wall(context: AppContext, wall_id: str, state: WallState) -> Round | None:
    number = ImageState.of(state).quiz_round
    return quiz_of(context).get_round(wall_id, number) if number is not None else None


def hotspot_tag(hotspot_id: str, round_number: int | None) -> str:
    """A hotspot's tag name: new in every round, so a round's codes are its own."""
    return f"image:{hotspot_id}" + (f":r{round_number}" if round_number is not None else "")


def judge(spot: Hotspot, spots: list[Hotspot], text: str) -> bool:
    """Whether ``text`` answers ``spot`` (tolerantly; a typo may not make it another
    hotspot's answer)."""
    others = [answer for other in spots if other.id != spot.id for answer in other.accepted]
    return matches(text, spot.accepted, others)


def reveals_answers(person: Person) -> bool:
    """The one rule for early answers: instructors see them at once; students when
    their round says so (``Round.names_shown``)."""
    return person.is_staff


def start_round(
    context: AppContext, store: ImageStore, wall_id: str, image_id: str, by: str
) -> Round:
    """A new round of ``image_id``'s questions on the wall (the one before closes):
    fresh numbers, so fresh codes once the wall shows it (a worker thread)."""
    spots = hotspots(store, image_id)
    return quiz_of(context).start_round(wall_id, by, fresh_orders(image_id, spots))
