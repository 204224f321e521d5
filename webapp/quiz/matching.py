"""Tolerant matching of a typed answer against an item's accepted answers, for any app
whose answers are a short list of words (an image's hotspots). The brain atlas has its
own, richer key (synonyms, abbreviations, Latin names) in its ``matching`` module.

A phone keyboard adds capitals, accents, punctuation and stray spaces, and a student
misspells a long word now and then: none of that makes an answer wrong. One typo (a
letter added, dropped, changed, or two swapped) is forgiven in answers of
:data:`TYPO_LETTERS` letters or more, unless the answer is as close to another item's
accepted answer: a typo never turns one item's answer into another's.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Iterable

TYPO_LETTERS = 8


def normal(text: str) -> str:
    """``text`` as answers are compared: casefolded, accents dropped, punctuation made
    spaces, runs of spaces one."""
    decomposed = unicodedata.normalize("NFKD", text.casefold())
    kept = "".join(c if c.isalnum() else " " for c in decomposed if not unicodedata.combining(c))
    return " ".join(kept.split())


def one_typo(a: str, b: str) -> bool:
    """Whether ``a`` and ``b`` differ by exactly one edit (insert, delete, substitute,
    or two neighbours swapped)."""
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        diff = [i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x != y]
        if len(diff) == 1:
            return True
        i = diff[0]
        return len(diff) == 2 and diff[1] == i + 1 and a[i] == b[i + 1] and a[i + 1] == b[i]
    short, long = (a, b) if len(a) < len(b) else (b, a)
    i = next((i for i, (x, y) in enumerate(zip(short, long, strict=False)) if x != y), len(short))
    return short[i:] == long[i + 1 :]


def matches(answer: str, accepted: Iterable[str], others: Iterable[str] = ()) -> bool:
    """Whether ``answer`` is one of ``accepted`` (tolerantly, above); ``others`` are the
    accepted answers of the other items asked alongside, which a typo may not reach."""
    typed = normal(answer)
    if not typed:
        return False
    keys = {normal(a) for a in accepted} - {""}
    if typed in keys:
        return True
    if sum(c.isalnum() for c in typed) < TYPO_LETTERS:
        return False
    rivals = {normal(o) for o in others} - keys
    if typed in rivals or any(one_typo(typed, rival) for rival in rivals):
        return False
    return any(one_typo(typed, key) for key in keys)
