"""The brain atlas's slot of the wall state: the quiz round whose pins stand on the wall."""

from __future__ import annotations

from typing import ClassVar

from webapp.apps.brain_atlas.rules import APP
from webapp.database.connection import RowId
from webapp.engine.wall_state import AppState


class BrainState(AppState):
    app: ClassVar[str] = APP
    placing: ClassVar[frozenset[str]] = frozenset({"quiz_round"})  # a round: new pin codes

    quiz_round: RowId | None = None  # the round whose pins stand on the wall (None: none yet)

    def later_round(self, number: int) -> BrainState:
        """The slot showing round ``number`` unless a later one is already up (two
        instructors starting rounds at once: the wall keeps the newest)."""
        return BrainState(quiz_round=max(number, self.quiz_round or 0))
