"""Tolerant answer matching for the brain atlas quiz.

A student scans a pin and types the region's name on a phone, so answers arrive in any
case, with or without accents, hyphens, a side ("left", "R", "(lh)") or filler words,
in any word order, without the head noun ("precentral" for "precentral gyrus") and
with typos. :class:`AnswerKey` decides whether an answer names a given region, and
which region an answer names at all (for the class's statistics of wrong answers).

Typos are forgiven only where that cannot turn one name into another's: a typo is
accepted for a region only if no name of any other region lies within the same edit
distance, and neither does the name of any *competitor*: an atlas region the quiz
leaves out ("pars orbitalis", "cuneus"), which is always a wrong answer, nor that of
an atlas region another region is made of (a *part*). So a real name of a neighbouring
region is always judged as that region, never as a typo.

A name without its head noun (:data:`HEAD_NOUNS`) is accepted when that shortened
form is unambiguous: no other region or competitor is called that, or shortens to it
("superior frontal" names the superior frontal gyrus; "frontal" alone names nothing
in a key that also holds the middle frontal gyrus and the frontal pole).
"""

from __future__ import annotations

import itertools
import unicodedata
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from webapp.apps.brain_atlas.content import AtlasContent, Hemisphere, Region, TagSetName
from webapp.quiz.engine import MAX_ANSWER_LENGTH

FILLER_WORDS = frozenset({"the", "a", "an", "of", "area", "region"})
"""Words left out of every name and answer (unless nothing else is left)."""
LEFT_WORDS = frozenset({"left", "l", "lh"})
RIGHT_WORDS = frozenset({"right", "r", "rh"})
SIDE_COMPANIONS = frozenset({"hemisphere", "hemispheres", "side", "sided"})
"""Words dropped when next to a side word ("left hemisphere", "right-sided")."""

HEAD_NOUNS = frozenset(
    {"gyrus", "gyri", "cortex", "cortices", "lobe", "lobes", "lobule", "lobules"}
    | {"nucleus", "nuclei", "sulcus", "sulci"}
)
"""The anatomical head nouns an answer may leave out of a name: "precentral" for
"Precentral gyrus", "caudate" for "Caudate nucleus", "insular" for "Insular cortex",
"frontal" for "Frontal lobe". "area" and "region" need no entry here: they are filler
words, left out of every name anyway. Parts that narrow a name down ("pole", "pars",
"strip") are not head nouns: "temporal" never means the temporal pole."""

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


MAX_COMPANIONS_KEPT = 3
"""Answers with more companions of side words than this are read only with all of them
dropped or all kept (cost bound: each subset is one more reading)."""


def _companions(words: Sequence[str]) -> list[int]:
    """Where the companions of side words are ("side" in "left side")."""
    is_side = [w in LEFT_WORDS or w in RIGHT_WORDS for w in words]
    return [
        i
        for i, word in enumerate(words)
        if word in SIDE_COMPANIONS
        and ((i > 0 and is_side[i - 1]) or (i + 1 < len(words) and is_side[i + 1]))
    ]


def _split_sides(
    words: Sequence[str], keep: Iterable[int] = ()
) -> tuple[list[str], frozenset[Hemisphere]]:
    """Remove side words ("L", "right", "lh", "left hemisphere") from anywhere in the
    words, and say which sides were stated. Companions of side words are removed too,
    except those at the positions in ``keep`` (for names that contain one: "side lobe"
    in "left side lobe")."""
    sides: set[Hemisphere] = set()
    dropped = set(_companions(words)) - set(keep)
    kept: list[str] = []
    for i, word in enumerate(words):
        if word in LEFT_WORDS:
            sides.add("left")
        elif word in RIGHT_WORDS:
            sides.add("right")
        elif i not in dropped:
            kept.append(word)
    return kept, frozenset(sides)


def _drop_fillers(words: Sequence[str]) -> list[str]:
    """Remove filler words, unless that leaves nothing (a name made only of them)."""
    kept = [w for w in words if w not in FILLER_WORDS]
    return kept if kept else list(words)


def _name_words(name: str) -> list[str]:
    """A name's words as answers are compared with them: sides and fillers left out."""
    return _drop_fillers(_split_sides(_words(name))[0])


def _shortened(words: Sequence[str]) -> list[str] | None:
    """A name's words without its head nouns, or None if it has none (or nothing else)."""
    kept = [w for w in words if w not in HEAD_NOUNS]
    return kept if kept and len(kept) < len(words) else None


@dataclass(frozen=True, slots=True)
class _Form:
    """One way of naming an entry (a name, a synonym, or one of them without its head
    noun), normalised once when the key is built."""

    entry: int  # index into the key's entries: regions, then competitors, then parts
    words: tuple[str, ...]  # in the order written
    written: str  # the words joined in written order
    ordered: str  # the words sorted and joined: word order does not matter
    limit: int  # typos forgiven for this name

    @classmethod
    def of(cls, entry: int, words: Sequence[str]) -> _Form:
        return cls(
            entry=entry,
            words=tuple(words),
            written=" ".join(words),
            ordered=" ".join(sorted(words)),
            limit=allowed_distance(sum(len(w) for w in words)),
        )


@dataclass(frozen=True, slots=True)
class _Answer:
    """A student's answer, normalised once per call."""

    sides: frozenset[Hemisphere]
    words: tuple[str, ...]  # side and filler words removed, in typed order
    written: str
    ordered: str
    compact: tuple[str, ...]  # the forms an abbreviation is compared with


def _parses(answer: str) -> list[_Answer]:
    """The ways to read an answer, normalised: first with every companion of a side
    word dropped ("left side" is a side), then keeping some of them, in case they
    belong to the name ("left side lobe" is the K-5 "side lobe" too). No reading at
    all for an answer that cannot name anything (empty, only a side, too long)."""
    if len(answer) > MAX_ANSWER_LENGTH:
        return []
    folded = _words(answer)
    companions = _companions(folded)
    if len(companions) > MAX_COMPANIONS_KEPT:
        keeps: list[tuple[int, ...]] = [(), tuple(companions)]
    else:
        keeps = [
            kept
            for size in range(len(companions) + 1)
            for kept in itertools.combinations(companions, size)
        ]
    readings: list[_Answer] = []
    seen: list[list[str]] = []
    for keep in keeps:
        words, sides = _split_sides(folded, keep)
        if not words or words in seen:
            continue
        seen.append(words)
        meaningful = _drop_fillers(words)
        readings.append(
            _Answer(
                sides=sides,
                words=tuple(meaningful),
                written=" ".join(meaningful),
                ordered=" ".join(sorted(meaningful)),
                compact=tuple(dict.fromkeys(("".join(meaningful), "".join(words)))),
            )
        )
    return readings


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

    ``regions`` are those of one tag set (a quiz is always taken within one): which
    names count as "another region's" depends on which regions are in the key.

    ``competitors`` are names that are wrong for every region: the atlas regions the
    set leaves out ("pars orbitalis" in the full set). They are never accepted, keep
    typos off themselves, and :meth:`competitor` says which one an answer names. A
    competitor called exactly what a region is called is no rival of that region.

    ``parts`` maps a region's id to the names of the atlas regions it is made of (the
    K-5 frontal lobe's "Paracentral lobule"). A part is accepted only where it is also
    a name of its region, and keeps the *other* regions' typos off itself ("paracentral"
    is no typo of the K-5 movement strip's "precentral").

    :func:`answer_key` builds a set's key with
    both from the atlas names.
    """

    def __init__(
        self,
        regions: Sequence[Region],
        competitors: Iterable[str] = (),
        parts: Mapping[str, Iterable[str]] | None = None,
    ) -> None:
        self._ids: list[str] = []  # the regions' ids; entries 0 .. len - 1
        self._competitors: list[str] = []  # as given; the entries after the regions
        self._index: dict[str, int] = {}
        self._hemispheres: list[Hemisphere] = []  # per entry
        names: list[list[str]] = []  # per entry
        for number, region in enumerate(regions):
            if region.id in self._index:
                raise ValueError(f"region {region.id!r} is in the answer key twice")
            self._index[region.id] = number
            self._ids.append(region.id)
            self._hemispheres.append(region.hemisphere)
            names.append([region.name, *region.synonyms])
        seen: set[str] = set()
        for name in competitors:
            ordered = " ".join(sorted(_name_words(name)))
            if ordered and ordered not in seen:
                seen.add(ordered)
                self._competitors.append(name)
                self._hemispheres.append("both")
                names.append([name])
        # Parts: one entry per name (left and right regions may share one), after the
        # competitors; they accept nothing.
        self._accepting = len(names)  # entries from here on are parts
        self._owners: list[frozenset[int]] = [frozenset()] * len(names)  # per entry
        owners: dict[str, tuple[str, set[int]]] = {}
        for region_id, part_names in (parts or {}).items():
            if region_id not in self._index:
                raise ValueError(f"parts of {region_id!r}, which is not in the answer key")
            for name in part_names:
                ordered = " ".join(sorted(_name_words(name)))
                if ordered:
                    owners.setdefault(ordered, (name, set()))[1].add(self._index[region_id])
        for name, owning in owners.values():
            self._hemispheres.append("both")
            self._owners.append(frozenset(owning))
            names.append([name])
        self._forms: list[_Form] = []
        self._own: list[frozenset[str]] = []  # per entry: the forms accepted exactly
        self._reach: list[list[int]] = []  # per entry: indices of its accepted forms
        self._by_ordered: dict[str, set[int]] = {}
        self._add_names(names)
        self._abbreviations: list[tuple[str, int]] = []
        self._by_abbreviation: dict[str, set[int]] = {}
        self._own_abbreviations: list[frozenset[str]] = []
        for number, region in enumerate(regions):
            self._add_abbreviations(number, region.abbreviations)
        self._own_abbreviations += [frozenset()] * (len(names) - len(self._ids))

    def _add_names(self, names: Sequence[Sequence[str]]) -> None:
        """Normalise every entry's names into forms, and decide which shortened forms
        (head noun left out) are unambiguous enough to accept."""
        full: list[dict[str, _Form]] = []
        for entry, texts in enumerate(names):
            own: dict[str, _Form] = {}
            for text in texts:
                words = _name_words(text)
                if words:
                    form = _Form.of(entry, words)
                    own.setdefault(form.ordered, form)
            full.append(own)
        # Shortened forms, each with the names it shortens; and who claims each form.
        shorts: list[dict[str, tuple[_Form, set[str]]]] = []
        claims: dict[str, set[int]] = {}
        for entry, own in enumerate(full):
            mine: dict[str, tuple[_Form, set[str]]] = {}
            for ordered, form in own.items():
                claims.setdefault(ordered, set()).add(entry)
                kept = _shortened(form.words)
                if kept is not None:
                    short = _Form.of(entry, kept)
                    if short.ordered not in own:
                        mine.setdefault(short.ordered, (short, set()))[1].add(ordered)
            for ordered in mine:
                claims.setdefault(ordered, set()).add(entry)
            shorts.append(mine)
        for entry, own in enumerate(full):
            if entry >= self._accepting:
                accepted: set[str] = set()  # a part: only ever a rival
            else:
                accepted = set(own)
            for ordered in shorts[entry] if accepted else ():
                # Unambiguous unless another entry is called that, or shortens to it
                # from a name this entry does not share (left and right regions of
                # one name share their shortened forms too), or a part of another
                # region does.
                if all(
                    entry in self._owners[other]
                    or (ordered not in full[other] and shorts[other][ordered][1] <= own.keys())
                    for other in claims[ordered] - {entry}
                ):
                    accepted.add(ordered)
            self._own.append(frozenset(accepted))
            reach: list[int] = []
            for form in [*own.values(), *(short for short, _ in shorts[entry].values())]:
                if form.ordered in accepted:
                    reach.append(len(self._forms))
                    self._by_ordered.setdefault(form.ordered, set()).add(entry)
                self._forms.append(form)  # ambiguous shortened forms keep typos off
            self._reach.append(reach)

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
        if region is None:
            return False
        return any(
            self._accepts(region, parsed, _Distances(parsed, self._forms))
            for parsed in _parses(answer)
        )

    def best(self, answer: str) -> str | None:
        """The id of the region ``answer`` names, or None if it names none of the key's
        regions: nothing, a competitor, a part of a region that is not its name, or a
        typo as near to another name (for the class's statistics).

        Always one that :meth:`judge` accepts the answer for; when several do (regions
        sharing a name, e.g. a left and a right one, and no side given), the one on
        the stated side wins, then the first in the key.
        """
        accepted, sides = self._naming(answer)
        regions = [entry for entry in accepted if entry < len(self._ids)]
        if not regions:
            return None
        for region in regions:
            if self._hemispheres[region] in sides:
                return self._ids[region]
        return self._ids[regions[0]]

    def competitor(self, answer: str) -> str | None:
        """The competitor ``answer`` names (as it was given to the key), when it names
        no region of the key: "which region left out of the quiz did they mean"."""
        accepted, _ = self._naming(answer)
        if not accepted or accepted[0] < len(self._ids):
            return None
        return self._competitors[accepted[0] - len(self._ids)]

    def _naming(self, answer: str) -> tuple[list[int], frozenset[Hemisphere]]:
        """The entries (regions, then competitors) that accept ``answer`` in any of
        its readings, in key order; and the sides it states."""
        accepted: set[int] = set()
        sides: frozenset[Hemisphere] = frozenset()
        for parsed in _parses(answer):
            distances = _Distances(parsed, self._forms)
            sides = parsed.sides
            accepted.update(
                entry for entry in range(self._accepting) if self._accepts(entry, parsed, distances)
            )
        return sorted(accepted), sides

    def _accepts(self, entry: int, answer: _Answer, distances: _Distances) -> bool:
        """The rules: the side must not contradict; an exact name, synonym,
        unambiguous shortened name or abbreviation counts; a typo counts only if no
        other entry's name (nor an ambiguous shortened one) is as close."""
        if not _side_allows(self._hemispheres[entry], answer.sides):
            return False
        if entry in self._by_ordered.get(answer.ordered, ()):
            return True
        if any(entry in self._by_abbreviation.get(c, ()) for c in answer.compact):
            return True
        reach = [
            (distance, self._forms[i].limit)
            for i in self._reach[entry]
            if (distance := distances.to_form(i)) <= self._forms[i].limit
        ]
        if not reach:
            return False
        # The nearest name within its reach sets the limit (the most lenient one if
        # several are as near); any rival name within that limit vetoes.
        nearest = min(distance for distance, _ in reach)
        allowed = max(limit for distance, limit in reach if distance == nearest)
        return not self._rival(entry, distances, allowed)

    def _rival(self, entry: int, distances: _Distances, limit: int) -> bool:
        """Whether a form this entry does not accept (another region's or competitor's
        name, a part of another region, an ambiguous shortened name) or another
        region's abbreviation lies within ``limit`` of the answer."""
        own = self._own[entry]
        for index, form in enumerate(self._forms):
            if form.ordered in own or entry in self._owners[form.entry]:
                continue
            if distances.to_form(index) <= limit:
                return True
        own_abbreviations = self._own_abbreviations[entry]
        for abbreviation, other in self._abbreviations:
            if other == entry or abbreviation in own_abbreviations:
                continue
            if distances.to_abbreviation(abbreviation) <= limit:
                return True
        return False


def answer_key(content: AtlasContent, tag_set: TagSetName) -> AnswerKey:
    """The answer key of one tag set's quiz: its regions, the atlas regions it leaves
    out as competitors, and the atlas regions each region is made of as its parts.
    Names need only be unique within a set, so there is one key per set."""
    return AnswerKey(
        content.in_set(tag_set),
        competitors=content.competitors(tag_set),
        parts=content.parts(tag_set),
    )
