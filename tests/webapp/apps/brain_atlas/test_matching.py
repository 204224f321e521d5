"""Quiz answer matching: forgiving about case, accents, separators, word order, sides
and typos, but never so forgiving that one region's name is taken for another's."""

from __future__ import annotations

import itertools
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from webapp.apps.brain_atlas.content import Hemisphere, Region
from webapp.apps.brain_atlas.matching import AnswerKey, allowed_distance, edit_distance


def region(
    id: str,
    name: str,
    hemisphere: Hemisphere = "both",
    synonyms: tuple[str, ...] = (),
    abbreviations: tuple[str, ...] = (),
) -> Region:
    return Region(
        id=id,
        name=name,
        synonyms=list(synonyms),
        abbreviations=list(abbreviations),
        hemisphere=hemisphere,
        labels=[1],
        sets=["full"],
    )


REGIONS = [
    region(
        "precentral",
        "Precentral gyrus",
        "left",
        ("primary motor cortex", "motor strip"),
        ("PrCG", "M1"),
    ),
    region("postcentral", "Postcentral gyrus", "left", abbreviations=("PoCG",)),
    region("caudate", "Caudate", "left", ("caudate nucleus",)),
    region("cuneus", "Cuneus", "right"),
    region("hippocampus", "Hippocampus"),
    region("amygdala", "Amygdala", "right"),
    region("pars-opercularis", "Pars opercularis", "left"),
    region("insula", "Insula", synonyms=("insular cortex",)),
    region("brainstem", "Brainstem"),
    region("stg", "Superior temporal gyrus", abbreviations=("STG",)),
    region("itg", "Inferior temporal gyrus", abbreviations=("ITG",)),
    region("mtg", "Middle temporal gyrus", abbreviations=("MTG",)),
]
KEY = AnswerKey(REGIONS)
IDS = [r.id for r in REGIONS]
BY_ID = {r.id: r for r in REGIONS}


def names(r: Region) -> list[str]:
    return [r.name, *r.synonyms]


def forms(r: Region) -> list[str]:
    return [*names(r), *r.abbreviations]


# --- the table -------------------------------------------------------------------------

ACCEPTED = {
    "precentral": [
        "Precentral gyrus",
        "PRECENTRAL GYRUS",
        "gyrus precentral",
        "precentral-gyrus",
        "  precentral \t  gyrus  ",
        "précentral gyrus",
        "the precentral gyrus",
        "precentral gyrus area",
        "precentral gyrus region",
        "left precentral gyrus",
        "Precentral gyrus (left)",
        "L. precentral gyrus",
        "precentral gyrus L",
        "lh precentral gyrus",
        "precentral gyrus, left hemisphere",
        "left-sided precentral gyrus",
        "primary motor cortex",
        "the motor strip",
        "strip motor",
        "M1",
        "m1",
        "M-1",
        "left M1",
        "PrCG",
        "prcg",
        "L PrCG",
        "precentrall gyrus",
        "precentarl gyrus",
        "precentral gyros",
        "precentrl gyrs",
        "primary motr cortex",
        "motor strp",
    ],
    "postcentral": [
        "postcentral gyrus",
        "Gyrus, postcentral",
        "postcentrl gyrus",
        "postcentral gyrus (L)",
        "PoCG",
    ],
    "caudate": [
        "caudate",
        "Caudate nucleus",
        "nucleus caudate",
        "the caudate (L)",
        "caudat",
        "cuadate",
        "caudate nucleos",
    ],
    "cuneus": ["cuneus", "Cuneus right", "R cuneus", "rh cuneus", "(right) cuneus", "cunues"],
    "hippocampus": [
        "hippocampus",
        "Hippocámpus",
        "HIPPOCAMPUS",
        "left hippocampus",
        "right hippocampus",
        "hippocampus (R)",
        "hipocampus",
        "hippocampsu",
        "hipocampsu",
    ],
    "amygdala": ["amygdala", "the amygdala", "amygdala right", "amygdla", "amigdala"],
    "pars-opercularis": [
        "pars opercularis",
        "pars-opercularis",
        "opercularis pars",
        "Pars Opercularis, L",
        "pars opercularis of the left hemisphere",
        "parsopercularis",
        "pars opercularus",
    ],
    "insula": [
        "insula",
        "Insula (left)",
        "insular cortex",
        "cortex insular",
        "insular",
        "insular cortx",
    ],
    "brainstem": ["brainstem", "brain stem", "brain-stem", "Brainstem (left)", "brianstem"],
    "stg": [
        "superior temporal gyrus",
        "superier temporal gyrus",
        "temporal gyrus superior",
        "superior-temporal gyrus, right hemisphere",
        "STG",
        "s.t.g.",
        # a typo in a first letter, with the words reordered: still aligned word by word
        "remporal gyrus superior",
    ],
    "itg": ["inferior temporal gyrus", "inferior temporal gyros", "ITG"],
    "mtg": ["middle temporal gyrus", "midle temporal gyrus", "mtg"],
}

REJECTED = {
    "precentral": [
        "right precentral gyrus",
        "precentral gyrus R",
        "rh precentral gyrus",
        "precentral gyrus (right hemisphere)",
        "left and right precentral gyrus",
        "R M1",
        "postcentral gyrus",
        "left postcentral gyrus",
        "M2",  # abbreviations are never matched by distance
        "PrC",
        "PrCGG",
        "precentral",
        "premotor cortex",
        "superior temporal gyrus",
    ],
    "postcentral": [
        "precentral gyrus",
        "right postcentral gyrus",
        "pstcentral gyrus",  # as close to "precentral gyrus" as the limit allows
        "M1",
    ],
    "caudate": ["cuneus", "right caudate", "caud", "caudatte nucleuss putamen", "cuneate"],
    "cuneus": ["left cuneus", "caudate", "cuneos nucleus"],
    "hippocampus": ["hippo", "campus", "hipcampos", "amygdala"],
    "amygdala": ["left amygdala", "amigdila", "hippocampus"],
    "pars-opercularis": ["pars triangularis", "right pars opercularis", "opercularis"],
    "insula": ["insulin", "cortex", "insular gyrus"],
    "brainstem": ["brain", "stem"],
    "stg": [
        "inferior temporal gyrus",
        "middle temporal gyrus",
        "ITG",
        "STGG",
        "superior temporal",
        # one edit from "superior", but within the limit (3) of "inferior temporal gyrus"
        "suberior temporal gyrus",
    ],
    "itg": ["superior temporal gyrus", "middle temporal gyrus", "STG", "inferior gyrus"],
    "mtg": ["superior temporal gyrus", "inferior temporal gyrus", "MTG gyrus"],
}

NONSENSE = ["", " ", " \t\n ", "left", "L.", "(right)", "lh rh", "the area", "?!", "x" * 201]


def cases(table: dict[str, list[str]]) -> list[tuple[str, str]]:
    return [(rid, answer) for rid, answers in table.items() for answer in answers]


@pytest.mark.parametrize(("region_id", "answer"), cases(ACCEPTED))
def test_accepted(region_id: str, answer: str) -> None:
    assert KEY.judge(region_id, answer)
    assert KEY.best(answer) == region_id


@pytest.mark.parametrize(("region_id", "answer"), cases(REJECTED))
def test_rejected(region_id: str, answer: str) -> None:
    assert not KEY.judge(region_id, answer)
    assert KEY.best(answer) != region_id


@pytest.mark.parametrize("answer", NONSENSE)
def test_nonsense_names_nothing(answer: str) -> None:
    assert not any(KEY.judge(rid, answer) for rid in IDS)
    assert KEY.best(answer) is None


@pytest.mark.parametrize(
    ("answer", "expected"),
    [
        ("inferior temporal gyrus", "itg"),
        ("middle temporal gyrus", "mtg"),
        ("cuneus", "cuneus"),
        ("M1", "precentral"),
        ("superier temporal gyrus", "stg"),
        ("suberior temporal gyrus", None),  # ambiguous: counted as no region at all
        ("right precentral gyrus", None),  # no region in the key is on that side
        ("putamen", None),
    ],
)
def test_best(answer: str, expected: str | None) -> None:
    assert KEY.best(answer) == expected


def test_overlong_answer_is_rejected_even_if_it_is_a_name() -> None:
    padded = "precentral gyrus" + " " * 185
    assert len(padded) == 201
    assert not KEY.judge("precentral", padded)
    assert KEY.judge("precentral", padded[:200])


def test_unknown_region_is_never_right() -> None:
    assert not KEY.judge("putamen", "putamen")


def test_duplicate_region_ids_are_refused() -> None:
    with pytest.raises(ValueError, match="twice"):
        AnswerKey([REGIONS[0], REGIONS[0]])


def test_filler_words_only_as_whole_words() -> None:
    key = AnswerKey([region("area-x", "Areal gyrus"), region("theta", "Thalamus")])
    assert key.judge("area-x", "areal gyrus")
    assert key.judge("area-x", "the areal gyrus")
    assert not key.judge("area-x", "al gyrus")
    assert key.judge("theta", "the thalamus")


def test_a_typo_never_takes_one_real_name_for_another() -> None:
    """ "caudate" and "cuneate" are 3 edits apart (beyond 1 for seven letters); each is
    its own region, and an answer between two names one edit apart belongs to neither."""
    key = AnswerKey(
        [
            region("caudate", "Caudate"),
            region("cuneate", "Cuneate"),
            region("caudale", "Caudale"),  # one edit from "caudate"
        ]
    )
    assert key.best("cuneate") == "cuneate"
    assert not key.judge("caudate", "cuneate")
    assert key.best("caudale") == "caudale"
    assert not key.judge("caudate", "caudale")
    assert not key.judge("caudale", "caudate")
    assert key.best("cuneat") == "cuneate"
    # one edit from both "caudate" and "caudale": neither gets it
    assert not key.judge("caudate", "caudabe")
    assert not key.judge("caudale", "caudabe")
    assert key.best("caudabe") is None


def test_the_key_decides_what_is_a_rival() -> None:
    """Without "inferior temporal gyrus" in the key, its near-miss is a plain typo."""
    alone = AnswerKey([BY_ID["stg"], BY_ID["mtg"]])
    assert alone.judge("stg", "suberior temporal gyrus")
    assert not KEY.judge("stg", "suberior temporal gyrus")


def test_left_and_right_regions_sharing_a_name() -> None:
    key = AnswerKey(
        [
            region("precentral-left", "Precentral gyrus", "left"),
            region("precentral-right", "Precentral gyrus", "right"),
        ]
    )
    for rid in ("precentral-left", "precentral-right"):
        assert key.judge(rid, "precentral gyrus")
        assert key.judge(rid, "precentrl gyrus")  # the shared name is no rival
    assert key.judge("precentral-left", "left precentral gyrus")
    assert not key.judge("precentral-right", "left precentral gyrus")
    assert key.best("right precentrl gyrus") == "precentral-right"
    assert key.best("precentral gyrus L") == "precentral-left"
    assert key.best("precentral gyrus") == "precentral-left"  # the first in the key


@pytest.mark.parametrize(
    ("letters", "allowed"),
    [(1, 0), (4, 0), (5, 1), (8, 1), (9, 2), (15, 2), (16, 3), (60, 3)],
)
def test_allowed_distance(letters: int, allowed: int) -> None:
    assert allowed_distance(letters) == allowed


@pytest.mark.parametrize(
    ("a", "b", "distance"),
    [
        ("", "", 0),
        ("abc", "", 3),
        ("kitten", "sitting", 3),
        ("caudate", "cuneate", 3),
        ("ab", "ba", 1),
        ("ca", "abc", 3),  # optimal string alignment: no edits of a transposed pair
        ("hippocampus", "hippocampsu", 1),
    ],
)
def test_edit_distance(a: str, b: str, distance: int) -> None:
    assert edit_distance(a, b, 10) == distance
    assert edit_distance(a, b, distance) == distance
    if distance:
        assert edit_distance(a, b, distance - 1) == distance


# --- properties --------------------------------------------------------------------------


def reference_distance(a: str, b: str) -> int:
    """The unbounded optimal string alignment distance, written the textbook way."""
    d = [[0] * (len(b) + 1) for _ in range(len(a) + 1)]
    for i in range(len(a) + 1):
        d[i][0] = i
    for j in range(len(b) + 1):
        d[0][j] = j
    for i in range(1, len(a) + 1):
        for j in range(1, len(b) + 1):
            cost = 0 if a[i - 1] == b[j - 1] else 1
            d[i][j] = min(d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost)
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                d[i][j] = min(d[i][j], d[i - 2][j - 2] + 1)
    return d[len(a)][len(b)]


@given(
    st.text(alphabet="abcd", max_size=12),
    st.text(alphabet="abcd", max_size=12),
    st.integers(min_value=0, max_value=5),
)
def test_bounded_distance_agrees_with_the_textbook(a: str, b: str, limit: int) -> None:
    assert edit_distance(a, b, limit) == min(reference_distance(a, b), limit + 1)


EVERY_FORM = [(r.id, f, f in r.abbreviations) for r in REGIONS for f in forms(r)]
SEPARATORS = [" ", "  ", "-", "_", ",", ".", "/", "'", "(", ")", "\t", " - "]
SIDES: dict[str, list[str]] = {
    "left": ["left", "L", "L.", "lh", "(left)", "left hemisphere"],
    "right": ["right", "R", "R.", "rh", "(right)", "right hemisphere"],
}


@st.composite
def spelled(draw: st.DrawFn, text: str, shuffle: bool) -> str:
    """``text`` in random case, words maybe reordered, with extra separators around."""
    words = text.split()
    if shuffle:
        words = draw(st.permutations(words))
    separators = st.lists(st.sampled_from(SEPARATORS), max_size=2).map("".join)
    out = draw(separators)
    for word in words:
        cased = "".join(c.upper() if draw(st.booleans()) else c.lower() for c in word)
        out += cased + " " + draw(separators)
    return out


@given(st.sampled_from(EVERY_FORM), st.data())
def test_every_exact_form_is_accepted_however_spelled(
    entry: tuple[str, str, bool], data: st.DataObject
) -> None:
    rid, form, is_abbreviation = entry
    answer = data.draw(spelled(form, shuffle=not is_abbreviation))
    hemisphere = BY_ID[rid].hemisphere
    side_words = SIDES["left"] + SIDES["right"] if hemisphere == "both" else SIDES[hemisphere]
    side = data.draw(st.none() | st.sampled_from(side_words))
    if side is not None:
        answer = data.draw(st.sampled_from([f"{side} {answer}", f"{answer} {side}"]))
    assert KEY.judge(rid, answer), answer
    assert KEY.best(answer) == rid


@pytest.mark.parametrize("region_id", IDS)
def test_no_other_regions_name_is_ever_accepted(region_id: str) -> None:
    for other in REGIONS:
        if other.id == region_id:
            continue
        for form in forms(other):
            for answer in (form, form.upper(), f"the {form.lower()}"):
                assert not KEY.judge(region_id, answer), (region_id, answer)


@given(st.sampled_from(EVERY_FORM), st.sampled_from(IDS), st.data())
def test_no_other_regions_name_is_accepted_however_spelled(
    entry: tuple[str, str, bool], region_id: str, data: st.DataObject
) -> None:
    owner, form, is_abbreviation = entry
    answer = data.draw(spelled(form, shuffle=not is_abbreviation))
    assert KEY.judge(region_id, answer) == (region_id == owner)


def words_of(text: str) -> list[str]:
    return re.sub(r"[^a-z0-9]+", " ", text.lower()).split()


def oracle_distance(answer: list[str], name: list[str]) -> int:
    """How close an answer is to a name with its words in any order (brute force)."""
    sorted_pair = reference_distance(" ".join(sorted(answer)), " ".join(sorted(name)))
    return min(
        sorted_pair,
        *(reference_distance(" ".join(p), " ".join(name)) for p in itertools.permutations(answer)),
    )


def rival_within(region_id: str, answer: list[str], limit: int) -> bool:
    """Whether some other region has a name or abbreviation within ``limit``."""
    for other in REGIONS:
        if other.id == region_id:
            continue
        for name in names(other):
            if oracle_distance(answer, words_of(name)) <= limit:
                return True
        for abbreviation in other.abbreviations:
            if reference_distance("".join(answer), "".join(words_of(abbreviation))) <= limit:
                return True
    return False


LONG_NAMES = [
    (r.id, name)
    for r in REGIONS
    for name in names(r)
    if len(re.sub(r"[^a-z]", "", name.lower())) >= 9
]
LETTERS = "abcdefghijklmnopqrstuvwxyz"


@st.composite
def one_edit(draw: st.DrawFn, text: str) -> str:
    """``text`` with one letter inserted, deleted, substituted or transposed."""
    letters = [i for i, c in enumerate(text) if c.isalpha()]
    kind = draw(st.sampled_from(["insert", "delete", "substitute", "transpose"]))
    if kind == "insert":
        i = draw(st.integers(min_value=0, max_value=len(text)))
        return text[:i] + draw(st.sampled_from(LETTERS)) + text[i:]
    if kind == "delete":
        i = draw(st.sampled_from(letters))
        return text[:i] + text[i + 1 :]
    if kind == "substitute":
        i = draw(st.sampled_from(letters))
        c = draw(st.sampled_from(LETTERS.replace(text[i], "")))
        return text[:i] + c + text[i + 1 :]
    pairs = [i for i in letters if i + 1 in letters and text[i] != text[i + 1]]
    i = draw(st.sampled_from(pairs))
    return text[:i] + text[i + 1] + text[i] + text[i + 2 :]


@settings(max_examples=300)
@given(st.sampled_from(LONG_NAMES), st.booleans(), st.data())
def test_one_typo_in_a_long_name_is_forgiven_unless_it_nears_a_rival(
    entry: tuple[str, str], shuffle: bool, data: st.DataObject
) -> None:
    rid, name = entry
    edited = data.draw(one_edit(name.lower()))
    words = words_of(edited)
    if shuffle:
        words = data.draw(st.permutations(words))
    answer = " ".join(words)
    limit = allowed_distance(len("".join(words_of(name))))
    accepted = KEY.judge(rid, answer)
    assert accepted == (KEY.best(answer) == rid)
    if not rival_within(rid, words, limit):
        assert accepted, answer


ANSWER_PIECES = st.sampled_from(
    [
        *SEPARATORS,
        *SIDES["left"],
        *SIDES["right"],
        "the",
        "area",
        "of",
        "gyrus",
        "temporal",
        "superior",
        "m1",
        "hippocámpus",
        "\u0301",
        "ß",
        "\x00",
        "😀",
    ]
)


@settings(max_examples=300)
@given(st.one_of(st.text(max_size=250), st.lists(ANSWER_PIECES, max_size=40).map(" ".join)))
def test_arbitrary_text_never_raises_and_judge_agrees_with_best(answer: str) -> None:
    best = KEY.best(answer)
    accepted = [rid for rid in IDS if KEY.judge(rid, answer)]
    if best is None:
        assert accepted == []
    else:
        assert best in accepted
