"""Tolerant answer matching for the brain atlas quiz.

A student scans a pin and types the region's name on a phone, so answers arrive in any
case, with or without accents, hyphens, a side ("left", "R", "(lh)") or filler words,
in any word order and with typos. :class:`AnswerKey` decides whether an answer names a
given region, and which region an answer names at all (for the class's statistics of
wrong answers).

Typos are forgiven only where that cannot turn one region's name into another's: a
typo is accepted for a region only if no name of any other region lies within the same
edit distance, so a real name of a neighbouring region is always judged as that region.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from webapp.apps.brain_atlas.content import Hemisphere, Region

MAX_ANSWER_LENGTH = 200
"""Longer answers are rejected outright: nobody types a region's name that long, and it
keeps the cost of judging bounded."""

FILLER_WORDS = frozenset({"the", "a", "an", "of", "area", "region"})
LEFT_WORDS = frozenset({"left", "l", "lh"})
RIGHT_WORDS = frozenset({"right", "r", "rh"})
SIDE_COMPANIONS = frozenset({"hemisphere", "hemispheres", "side", "sided"})
"""Words dropped when next to a side word ("left hemisphere", "right-sided")."""

MAX_TYPO_DISTANCE = 3
"""The largest distance any name allows (see :func:`allowed_distance`)."""

MAX_ALIGNED_WORDS = 12
"""Answers with more words than this are not re-aligned word by word (cost bound)."""


def allowed_distance(letters: int) -> int:
    """How many typos a name of this many letters forgives: none for short names (they
    would collide with each other and with abbreviations), more for long ones."""
    if letters <= 4:
        return 0
    if letters <= 8:
        return 1
    if letters <= 15:
        return 2
    return 3


def edit_distance(a: str, b: str, limit: int) -> int:
    """The Damerau-Levenshtein distance (optimal string alignment: insertions, deletions,
    substitutions, adjacent transpositions) of ``a`` and ``b``, or ``limit + 1`` when it
    exceeds ``limit``.

    Bounded because it runs against every name on every answer: only a band of width
    ``2 * limit + 1`` is computed, and it stops as soon as a whole row exceeds the limit.
    """
    if a == b:
        return 0
    over = limit + 1
    la, lb = len(a), len(b)
    if limit < 0:
        return over
    if abs(la - lb) > limit:
        return over
    if la == 0 or lb == 0:
        return max(la, lb)
    before: list[int] = []
    previous = [min(j, over) for j in range(lb + 1)]
    for i in range(1, la + 1):
        current = [over] * (lb + 1)
        if i <= limit:
            current[0] = i
        row_min = current[0]
        ca = a[i - 1]
        for j in range(max(1, i - limit), min(lb, i + limit) + 1):
            cb = b[j - 1]
            value = min(
                previous[j] + 1,
                current[j - 1] + 1,
                previous[j - 1] + (ca != cb),
            )
            if i > 1 and j > 1 and ca == b[j - 2] and a[i - 2] == cb:
                value = min(value, before[j - 2] + 1)
            if value > over:
                value = over
            current[j] = value
            if value < row_min:
                row_min = value
        # Every later cell derives from this row (or the one before it, plus one
        # transposition, which is no cheaper), so nothing below can come back under.
        if row_min > limit:
            return over
        before, previous = previous, current
    return previous[lb]


def _fold(text: str) -> str:
    """Case-fold and strip accents, so "Hippocámpus" and "HIPPOCAMPUS" compare equal."""
    decomposed = unicodedata.normalize("NFKD", text.casefold())
    return "".join(c for c in decomposed if not unicodedata.combining(c))


def _words(text: str) -> list[str]:
    """The folded words of a text: anything that is not a letter or digit separates."""
    folded = _fold(text)
    return "".join(c if c.isalnum() else " " for c in folded).split()


def _split_sides(words: Sequence[str]) -> tuple[list[str], frozenset[Hemisphere]]:
    """Remove side words ("L", "right", "lh", "left hemisphere") from anywhere in the
    words, and say which sides were stated."""
    sides: set[Hemisphere] = set()
    is_side = [w in LEFT_WORDS or w in RIGHT_WORDS for w in words]
    kept: list[str] = []
    for i, word in enumerate(words):
        if word in LEFT_WORDS:
            sides.add("left")
        elif word in RIGHT_WORDS:
            sides.add("right")
        elif word in SIDE_COMPANIONS and (
            (i > 0 and is_side[i - 1]) or (i + 1 < len(words) and is_side[i + 1])
        ):
            pass
        else:
            kept.append(word)
    return kept, frozenset(sides)


def _drop_fillers(words: Sequence[str]) -> list[str]:
    """Remove filler words, unless that leaves nothing (a name made only of them)."""
    kept = [w for w in words if w not in FILLER_WORDS]
    return kept if kept else list(words)


@dataclass(frozen=True, slots=True)
class _Form:
    """One name or synonym of a region, normalised once when the key is built."""

    region: int  # index into the key's regions
    words: tuple[str, ...]  # in the order written
    written: str  # the words joined in written order
    ordered: str  # the words sorted and joined: word order does not matter
    limit: int  # typos forgiven for this name


@dataclass(frozen=True, slots=True)
class _Answer:
    """A student's answer, normalised once per call."""

    sides: frozenset[Hemisphere]
    words: tuple[str, ...]  # side and filler words removed, in typed order
    written: str
    ordered: str
    compact: tuple[str, ...]  # the forms an abbreviation is compared with


def _parse(answer: str) -> _Answer | None:
    """Normalise an answer, or None for one that cannot name anything (empty, only a
    side, too long)."""
    if len(answer) > MAX_ANSWER_LENGTH:
        return None
    words, sides = _split_sides(_words(answer))
    if not words:
        return None
    meaningful = _drop_fillers(words)
    return _Answer(
        sides=sides,
        words=tuple(meaningful),
        written=" ".join(meaningful),
        ordered=" ".join(sorted(meaningful)),
        compact=tuple(dict.fromkeys(("".join(meaningful), "".join(words)))),
    )


def _side_allows(hemisphere: Hemisphere, sides: frozenset[Hemisphere]) -> bool:
    """A lateral region rejects an answer that names the other side; "both" ignores it."""
    if hemisphere == "left":
        return "right" not in sides
    if hemisphere == "right":
        return "left" not in sides
    return True


def _aligned(answer: Sequence[str], name: Sequence[str]) -> str:
    """The answer's words reordered to follow the name's, each name word taking the
    closest unused answer word, so a typo in a word's first letter does not break the
    match when the student also changed the word order."""
    unused = list(answer)
    out: list[str] = []
    for word in name:
        if not unused:
            break
        best = min(
            range(len(unused)),
            key=lambda k: edit_distance(unused[k], word, MAX_TYPO_DISTANCE),
        )
        out.append(unused.pop(best))
    return " ".join(out + unused)


class _Distances:
    """One answer's distances to the key's forms, each computed at most once (bounded
    by the largest limit any name allows)."""

    def __init__(self, answer: _Answer, forms: Sequence[_Form]) -> None:
        self._answer = answer
        self._forms = forms
        self._names: dict[int, int] = {}
        self._abbreviations: dict[str, int] = {}

    def to_form(self, index: int) -> int:
        """Distance to a name or synonym, whatever the word order."""
        known = self._names.get(index)
        if known is not None:
            return known
        answer, form, limit = self._answer, self._forms[index], MAX_TYPO_DISTANCE
        if abs(len(answer.written) - len(form.written)) > limit:
            distance = limit + 1  # every reordering has the same length
        else:
            distance = edit_distance(answer.ordered, form.ordered, limit)
            if distance > 0:
                distance = min(distance, edit_distance(answer.written, form.written, limit))
            if distance > 0 and 1 < len(answer.words) <= MAX_ALIGNED_WORDS:
                aligned = _aligned(answer.words, form.words)
                distance = min(distance, edit_distance(aligned, form.written, limit))
        self._names[index] = distance
        return distance

    def to_abbreviation(self, abbreviation: str) -> int:
        """Distance to an abbreviation (only ever used to keep typos off it)."""
        known = self._abbreviations.get(abbreviation)
        if known is None:
            known = min(
                edit_distance(compact, abbreviation, MAX_TYPO_DISTANCE)
                for compact in self._answer.compact
            )
            self._abbreviations[abbreviation] = known
        return known


class AnswerKey:
    """The regions a quiz accepts answers for, with their names normalised up front.

    Built from the regions of the active tag set (or all regions): which names count
    as "another region's" depends on which regions are in the key.
    """

    def __init__(self, regions: Sequence[Region]) -> None:
        self._ids: list[str] = []
        self._hemispheres: list[Hemisphere] = []
        self._index: dict[str, int] = {}
        self._forms: list[_Form] = []
        self._own_forms: list[list[int]] = []
        self._own_ordered: list[frozenset[str]] = []
        self._own_abbreviations: list[frozenset[str]] = []
        self._by_ordered: dict[str, set[int]] = {}
        self._by_abbreviation: dict[str, set[int]] = {}
        self._abbreviations: list[tuple[str, int]] = []
        for number, region in enumerate(regions):
            if region.id in self._index:
                raise ValueError(f"region {region.id!r} is in the answer key twice")
            self._index[region.id] = number
            self._ids.append(region.id)
            self._hemispheres.append(region.hemisphere)
            self._add_names(number, [region.name, *region.synonyms])
            self._add_abbreviations(number, region.abbreviations)

    def _add_names(self, region: int, names: Iterable[str]) -> None:
        """Normalise a region's name and synonyms into forms (once each)."""
        own: list[int] = []
        seen: set[str] = set()
        for name in names:
            words = _drop_fillers(_split_sides(_words(name))[0])
            ordered = " ".join(sorted(words))
            if not words or ordered in seen:
                continue
            seen.add(ordered)
            own.append(len(self._forms))
            self._forms.append(
                _Form(
                    region=region,
                    words=tuple(words),
                    written=" ".join(words),
                    ordered=ordered,
                    limit=allowed_distance(sum(len(w) for w in words)),
                )
            )
            self._by_ordered.setdefault(ordered, set()).add(region)
        self._own_forms.append(own)
        self._own_ordered.append(frozenset(seen))

    def _add_abbreviations(self, region: int, abbreviations: Iterable[str]) -> None:
        """Abbreviations compare letters and digits only, in order: "M-1" is "m1"."""
        own: set[str] = set()
        for abbreviation in abbreviations:
            compact = "".join(_words(abbreviation))
            if compact and compact not in own:
                own.add(compact)
                self._abbreviations.append((compact, region))
                self._by_abbreviation.setdefault(compact, set()).add(region)
        self._own_abbreviations.append(frozenset(own))

    def judge(self, region_id: str, answer: str) -> bool:
        """Whether ``answer`` names the region ``region_id`` (False for an unknown id)."""
        region = self._index.get(region_id)
        parsed = _parse(answer)
        if region is None or parsed is None:
            return False
        return self._accepts(region, parsed, _Distances(parsed, self._forms))

    def best(self, answer: str) -> str | None:
        """The id of the region ``answer`` names, or None if it names none.

        Always one that :meth:`judge` accepts the answer for; when several do (regions
        sharing a name, e.g. a left and a right one, and no side given), the one on
        the stated side wins, then the first in the key.
        """
        parsed = _parse(answer)
        if parsed is None:
            return None
        distances = _Distances(parsed, self._forms)
        accepted = [r for r in range(len(self._ids)) if self._accepts(r, parsed, distances)]
        if not accepted:
            return None
        for region in accepted:
            if self._hemispheres[region] in parsed.sides:
                return self._ids[region]
        return self._ids[accepted[0]]

    def _accepts(self, region: int, answer: _Answer, distances: _Distances) -> bool:
        """The rules: the side must not contradict; an exact name, synonym or
        abbreviation counts; a typo counts only if no other region's name is as close."""
        if not _side_allows(self._hemispheres[region], answer.sides):
            return False
        if region in self._by_ordered.get(answer.ordered, ()):
            return True
        if any(region in self._by_abbreviation.get(c, ()) for c in answer.compact):
            return True
        reach = [
            (distance, self._forms[i].limit)
            for i in self._own_forms[region]
            if (distance := distances.to_form(i)) <= self._forms[i].limit
        ]
        if not reach:
            return False
        # The nearest name within its reach sets the limit (the most lenient one if
        # several are as near); any other region's name within that limit vetoes.
        nearest = min(distance for distance, _ in reach)
        allowed = max(limit for distance, limit in reach if distance == nearest)
        return self._rival(region, distances, allowed) is None

    def _rival(self, region: int, distances: _Distances, limit: int) -> int | None:
        """Another region with a name (or abbreviation) within ``limit`` of the answer."""
        own_ordered = self._own_ordered[region]
        for index, form in enumerate(self._forms):
            if form.region == region or form.ordered in own_ordered:
                continue
            if distances.to_form(index) <= limit:
                return form.region
        own_abbreviations = self._own_abbreviations[region]
        for abbreviation, other in self._abbreviations:
            if other == region or abbreviation in own_abbreviations:
                continue
            if distances.to_abbreviation(abbreviation) <= limit:
                return other
        return None
