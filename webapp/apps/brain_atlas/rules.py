"""The atlas's small rules, shared by its app, pages and routes: its modes and tag sets,
its quiz and a pin's question, which set a user group gets, who sees answers early, how
its tags are named."""

from __future__ import annotations

from typing import Literal

from webapp.apps.brain_atlas.content import Region, TagSetName
from webapp.core.roles import UserGroup
from webapp.engine.wall_state import WallState
from webapp.people.person import Person
from webapp.quiz.engine import Columns, Question, Quiz
from webapp.web.context import AppContext

APP = "brain"
Mode = Literal["quiz", "tutor"]
MODES: tuple[Mode, ...] = ("quiz", "tutor")
TAG_SETS: dict[TagSetName, str] = {"k5": "brain-k5", "full": "brain-full"}
GROUP_LABELS: dict[UserGroup, str] = {
    "k5": "K-5",
    "undergraduate": "Undergraduate",
    "medical": "Medical",
    "research": "Research",
}

ASKED: dict[TagSetName, str] = {
    "k5": "Look at the red pin on the wall. What part of the brain is it pointing at?"
    " Write its name.",
    "full": "What is this? Please enter the name of the tagged region.",
}
"""A pin's question, in the children's words for the K-5 pins."""
COLUMNS = Columns(set="tag_set", item="region")


def quiz_of(context: AppContext) -> Quiz:
    """The atlas's quiz: its rounds and answers in the shared quiz engine."""
    return Quiz(context.db, APP, COLUMNS)


def pin_question(region: Region, tag_set: TagSetName) -> Question:
    """A pin's question: its region's name, typed, judged by the atlas's answer key."""
    return Question(region.id, ASKED[tag_set])


def set_of_group(group: UserGroup) -> TagSetName:
    """Children get the K-5 pins; every other group the full set."""
    return "k5" if group == "k5" else "full"


def set_on_wall(state: WallState) -> TagSetName:
    """Which pins the wall shows now (the full set unless K-5 was chosen)."""
    return "k5" if state.tag_set == TAG_SETS["k5"] else "full"


def mode_of(state: WallState) -> Mode:
    return "tutor" if state.mode == "tutor" else "quiz"


def mode_of_class(chosen: str | None) -> Mode:
    """The mode a class starts in: the one chosen, quiz by default."""
    return "tutor" if chosen == "tutor" else "quiz"


def reveals_answers(person: Person) -> bool:
    """The one rule for early answers: instructors (and admins) see them at once;
    students only when their round says so (``Round.names_shown``)."""
    return person.is_staff


def pin_tag(tag_set: TagSetName, round_number: int, number: int) -> str:
    """A pin's tag name: new in every round, so every round has new codes."""
    return f"brain:{tag_set}:r{round_number}:pin:{number}"


def group_tag(group: UserGroup) -> str:
    return f"brain:group:{group}"
