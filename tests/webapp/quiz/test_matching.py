"""The generic tolerant matcher: case, accents, punctuation and spaces never count; one
typo in a long answer is forgiven unless it reaches another item's answer."""

from __future__ import annotations

import pytest

from webapp.quiz.matching import matches, normal, one_typo


def test_normal_folds_case_accents_punctuation_and_spaces() -> None:
    assert normal("  Éndoplasmic-RETICULUM!! ") == "endoplasmic reticulum"
    assert normal("Straße") == "strasse"
    assert normal("?!") == ""


@pytest.mark.parametrize(
    ("a", "b", "near"),
    [
        ("nucleus", "nucleas", True),  # changed
        ("nucleus", "nucleuss", True),  # added
        ("nucleus", "nuclus", True),  # dropped
        ("nucleus", "nuclues", True),  # two swapped
        ("nucleus", "nucleus", False),  # the same is no typo
        ("nucleus", "nuclaes", False),  # two changed
        ("nucleus", "nucl", False),
    ],
)
def test_one_typo(a: str, b: str, near: bool) -> None:
    assert one_typo(a, b) is near and one_typo(b, a) is near


def test_matches_tolerantly() -> None:
    accepted = ["Mitochondrion", "mitochondria"]
    assert matches("  MITOCHONDRION. ", accepted)
    assert matches("mitochondrión", accepted)
    assert matches("mitocondrion", accepted)  # one typo in 8+ letters
    assert not matches("mitocndrin", accepted)  # two
    assert not matches("", accepted) and not matches("...", accepted)


def test_short_answers_get_no_typo() -> None:
    assert matches("cell", ["Cell"])
    assert not matches("cel", ["cell"])
    assert not matches("nucleas", ["nucleus"])  # 7 letters


def test_a_typo_never_makes_another_items_answer() -> None:
    # "ribosomes" is one typo from "ribosome" but another item's answer outright
    assert not matches("ribosomes", ["ribosome"], others=["ribosomes"])
    # one typo from this item's answer and from another's: refused
    assert matches("lysosome", ["lysosomes"])
    assert not matches("lysosome", ["lysosomes"], others=["lysosoma"])
    assert matches("lysosomse", ["lysosomes"], others=["golgi body"])
