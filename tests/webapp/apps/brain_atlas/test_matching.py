"""Quiz answer matching: forgiving about case, accents, separators, word order, sides,
left-out head nouns and typos, but never so forgiving that one region's name, or the
name of an atlas region the quiz leaves out (a competitor), is taken for another's."""

from __future__ import annotations

import functools
import itertools
import re
from collections import Counter
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from webapp.apps.brain_atlas.content import Hemisphere, Region, TagSetName, load_content
from webapp.apps.brain_atlas.matching import (
    HEAD_NOUNS,
    AnswerKey,
    allowed_distance,
    answer_key,
    edit_distance,
)


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
# Atlas regions this key's quiz leaves out: always wrong, and typos keep off them.
COMPETITORS = [
    "Pars triangularis",
    "Paracentral lobule",  # "paracentral" is two edits from "precentral"
    "Lingual gyrus",
    "Cuneate nucleus",
    "Posterior cingulate cortex",
    "Middle temporal sulcus",  # "middle temporal" now shortens two names: neither's
]
# Atlas regions that make up a region of the key: only that region's, keep typos off.
PARTS = {
    "insula": ["Anterior insular cortex", "Posterior insular cortex"],
    "precentral": ["Precentral gyrus"],  # the region's own name: no rival of it
    "stg": ["Planum temporale"],
}
KEY = AnswerKey(REGIONS, competitors=COMPETITORS, parts=PARTS)
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
        # the head noun left out
        "precentral",
        "Precentral (left)",
        "left precentral",
        "precentrl",
        "primary motor",
    ],
    "postcentral": [
        "postcentral gyrus",
        "Gyrus, postcentral",
        "postcentrl gyrus",
        "postcentral gyrus (L)",
        "PoCG",
        "postcentral",
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
        "INSULAR (left)",
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
        "superior temporal",
        "temporal superior",
        "superior-temporal, right hemisphere",
    ],
    "itg": ["inferior temporal gyrus", "inferior temporal gyros", "ITG", "inferior temporal"],
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
        "premotor cortex",
        "superior temporal gyrus",
        "right precentral",
        # competitors: atlas regions the quiz leaves out
        "paracentral lobule",
        "paracentral",
        "paacentral",  # two typos from "precentral", but one from "paracentral"
        "gyrus",  # a head noun alone names nothing
        "motor",  # "motor strip" has no head noun to leave out
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
    "pars-opercularis": [
        "pars triangularis",
        "pars triangularis (left)",
        "pars triangularus",
        "right pars opercularis",
        "opercularis",  # "pars" is no head noun
    ],
    "insula": ["insulin", "cortex", "insular gyrus"],
    "brainstem": ["brain", "stem"],
    "stg": [
        "inferior temporal gyrus",
        "middle temporal gyrus",
        "ITG",
        "STGG",
        "superior",
        "temporal",
        # one edit from "superior", but within the limit (3) of "inferior temporal gyrus"
        "suberior temporal gyrus",
    ],
    "itg": ["superior temporal gyrus", "middle temporal gyrus", "STG", "inferior gyrus"],
    "mtg": [
        "superior temporal gyrus",
        "inferior temporal gyrus",
        "MTG gyrus",
        "middle temporal",  # the middle temporal sulcus's too
        "middle temporal sulcus",
    ],
}

NONSENSE = [
    *["", " ", " \t\n ", "left", "L.", "(right)", "lh rh", "the area", "?!", "x" * 201],
    *["gyrus", "cortex", "lobe", "the nucleus"],
]


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
    assert KEY.competitor(answer) is None


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
        ("precentral", "precentral"),
        ("superior temporal", "stg"),
        ("pars triangularis", None),  # a competitor: no region of the key
        ("paracentral", None),
    ],
)
def test_best(answer: str, expected: str | None) -> None:
    assert KEY.best(answer) == expected


@pytest.mark.parametrize(
    ("answer", "expected"),
    [
        ("pars triangularis", "Pars triangularis"),
        ("Triangularis pars (left)", "Pars triangularis"),
        ("pars triangularus", "Pars triangularis"),
        ("paracentral", "Paracentral lobule"),
        ("lingual", "Lingual gyrus"),
        ("posterior cingulate", "Posterior cingulate cortex"),
        ("cuneate", "Cuneate nucleus"),
        ("precentral gyrus", None),  # a region of the key
        ("cuneus", None),
        ("putamen", None),  # nothing the key knows
        ("", None),
    ],
)
def test_competitor(answer: str, expected: str | None) -> None:
    assert KEY.competitor(answer) == expected
    if expected is not None:
        assert KEY.best(answer) is None


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
    # ... and as a competitor it is as much a rival as a region is
    rivalled = AnswerKey([BY_ID["stg"]], competitors=["Inferior temporal gyrus"])
    assert not rivalled.judge("stg", "suberior temporal gyrus")
    assert rivalled.judge("stg", "superier temporal gyrus")
    assert rivalled.competitor("inferior temporal gyrus") == "Inferior temporal gyrus"


def test_a_competitor_is_never_accepted_nor_a_typo_near_it() -> None:
    """ "posterior cingulate cortex" is three edits from "anterior cingulate cortex",
    within what a name of 23 letters forgives: without the competitor it would pass."""
    acc = region("acc", "Anterior cingulate cortex", synonyms=("anterior cingulate",))
    bare = AnswerKey([acc])
    key = AnswerKey([acc], competitors=["Posterior cingulate cortex"])
    for answer in ("posterior cingulate cortex", "bosterior cingulate cortex"):
        assert bare.judge("acc", answer)
        assert not key.judge("acc", answer)
        assert key.best(answer) is None
    assert key.competitor("posterior cingulate cortex") == "Posterior cingulate cortex"
    assert key.competitor("posterior cingulate") == "Posterior cingulate cortex"
    assert key.judge("acc", "anterior cingulate cortex")
    assert key.judge("acc", "anterior cingulat cortex")
    assert key.judge("acc", "anterior cingulate")


def test_a_competitor_of_the_same_name_is_no_rival() -> None:
    """The atlas's "Precentral gyrus" is the quiz region itself, not a competitor."""
    pre = region("pre", "Precentral gyrus", "left")
    key = AnswerKey([pre], competitors=["Precentral gyrus", "Paracentral lobule"])
    for answer in ("precentral gyrus", "precentrl gyrus", "precentral", "precentrl"):
        assert key.judge("pre", answer), answer
        assert key.competitor(answer) is None
    assert key.best("paracentral") is None


def test_a_part_keeps_other_regions_typos_off_but_not_its_own() -> None:
    """In the K-5 set the paracentral lobule is part of the frontal lobe: two edits
    from "precentral" (the movement strip), so no typo of it; and the frontal pole,
    two edits from "frontal lobe", is no rival of the lobe it is part of."""
    regions = [
        region("movement", "Movement strip", synonyms=("precentral gyrus",)),
        region("frontal", "Frontal lobe"),
    ]
    bare = AnswerKey(regions)
    key = AnswerKey(regions, parts={"frontal": ["Paracentral lobule", "Frontal pole"]})
    assert bare.judge("movement", "paracentral")
    assert not key.judge("movement", "paracentral")
    assert key.best("paracentral") is None and key.competitor("paracentral") is None
    assert key.judge("movement", "precentral")
    assert key.judge("frontal", "frontal lole")  # one edit from each
    rivalled = AnswerKey(regions, competitors=["Frontal pole"])
    assert not rivalled.judge("frontal", "frontal lole")
    assert not key.judge("frontal", "paracentral lobule")  # a part, not the lobe's name
    with pytest.raises(ValueError, match="not in the answer key"):
        AnswerKey(regions, parts={"parietal": ["Precuneus"]})


def test_competitor_names_are_normalised_and_deduplicated() -> None:
    key = AnswerKey([], competitors=["Lingual gyrus", "LINGUAL  gyrus", "the area", ""])
    assert key.competitor("lingual-gyrus") == "Lingual gyrus"
    assert key.best("lingual gyrus") is None


@pytest.mark.parametrize("noun", sorted(HEAD_NOUNS))
def test_every_head_noun_may_be_left_out(noun: str) -> None:
    key = AnswerKey([region("x", f"Zygomatic {noun}")])
    assert key.judge("x", "zygomatic")
    assert key.judge("x", "zygomatik")  # a typo, within the short form's own limit
    assert not key.judge("x", noun)


def test_shortened_forms_must_be_unambiguous() -> None:
    """ "superior temporal" shortens both the gyrus and the sulcus: it names neither,
    and a typo near it is no typo of either."""
    stg = region("stg", "Superior temporal gyrus")
    key = AnswerKey([stg], competitors=["Superior temporal sulcus"])
    assert not key.judge("stg", "superior temporal")
    assert key.best("superior temporal") is None
    assert key.competitor("superior temporal") is None
    assert not key.judge("stg", "superior temporl")
    assert key.judge("stg", "superior temporal gyrus")
    assert key.competitor("superior temporal sulcus") == "Superior temporal sulcus"
    # a shortened form that is another region's whole name belongs to that region
    key = AnswerKey([region("caudate", "Caudate"), region("cn", "Caudate nucleus")])
    assert key.best("caudate") == "caudate"
    assert not key.judge("cn", "caudate")
    assert key.judge("cn", "caudate nucleus")
    # and two regions shortening to the same name share nothing
    key = AnswerKey([region("fl", "Frontal lobe"), region("fg", "Frontal gyrus")])
    assert not key.judge("fl", "frontal") and not key.judge("fg", "frontal")
    assert key.judge("fl", "frontal lobe") and key.judge("fg", "frontal gyrus")


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
        assert key.judge(rid, "precentral")  # nor its shortened form
    assert key.judge("precentral-left", "left precentral gyrus")
    assert not key.judge("precentral-right", "left precentral gyrus")
    assert key.best("right precentrl gyrus") == "precentral-right"
    assert key.best("precentral gyrus L") == "precentral-left"
    assert key.best("precentral gyrus") == "precentral-left"  # the first in the key


def test_a_side_companion_may_belong_to_the_name() -> None:
    """ "side" after "left" is usually part of the side ("left side"), but the K-5
    temporal lobe is also the "side lobe"."""
    key = AnswerKey(
        [
            region("temporal", "Temporal lobe", synonyms=("side lobe", "side of the brain")),
            region("pre", "Precentral gyrus", "left"),
        ]
    )
    for answer in ("left side lobe", "side lobe, right side", "lobe side left hemisphere"):
        assert key.judge("temporal", answer), answer
    assert key.judge("temporal", "left side of the brain")
    assert key.judge("pre", "left side precentral gyrus")
    assert not key.judge("pre", "right side precentral gyrus")
    assert key.best("left side lobe") == "temporal"


# --- the shipped content: one key per tag set -------------------------------------------


@dataclass(frozen=True)
class World:
    """A key with what it was built from, so that properties can be checked against
    an oracle written independently of the key's own bookkeeping."""

    name: str
    regions: list[Region]
    competitors: list[str]
    parts: dict[str, list[str]]
    key: AnswerKey

    @functools.cached_property
    def ids(self) -> list[str]:
        return [r.id for r in self.regions]

    @functools.cached_property
    def by_id(self) -> dict[str, Region]:
        return {r.id: r for r in self.regions}

    @functools.cached_property
    def every_form(self) -> list[tuple[str, str, bool]]:
        """(region id, name/synonym/abbreviation, whether an abbreviation)."""
        return [(r.id, f, f in r.abbreviations) for r in self.regions for f in forms(r)]

    @functools.cached_property
    def wrong_names(self) -> list[tuple[str | None, str]]:
        """Every name some region or competitor answers to: (owner or None, name)."""
        return [
            *((rid, f) for rid, f, _ in self.every_form),
            *((None, c) for c in self.competitors),
        ]

    @functools.cached_property
    def part_names(self) -> list[tuple[str, str]]:
        """(the region it is part of, name of a part)."""
        return [(rid, name) for rid, names in self.parts.items() for name in names]


SHIPPED = load_content()


def shipped(tag_set: TagSetName) -> World:
    return World(
        tag_set,
        SHIPPED.in_set(tag_set),
        SHIPPED.competitors(tag_set),
        SHIPPED.parts(tag_set),
        answer_key(SHIPPED, tag_set),
    )


TABLE = World("table", REGIONS, COMPETITORS, PARTS, KEY)
FULL = shipped("full")
K5 = shipped("k5")
WORLDS = [TABLE, FULL, K5]
EACH_WORLD = pytest.mark.parametrize("world", WORLDS, ids=[w.name for w in WORLDS])


SHIPPED_ACCEPTED: dict[tuple[TagSetName, str], list[str]] = {
    ("full", "precentral-gyrus"): ["Precentral gyrus", "precentral", "left precentral", "M1"],
    ("full", "superior-frontal-gyrus"): ["superior frontal", "Superior frontal gyrus", "SFG"],
    ("full", "middle-frontal-gyrus"): ["middle frontal", "DLPFC"],
    ("full", "supramarginal-gyrus"): ["supramarginal", "Supramarginal (L)"],
    ("full", "fusiform-gyrus"): ["fusiform", "fusiform gyrus", "fusifrom"],
    ("full", "pericalcarine-cortex"): ["pericalcarine", "primary visual cortex", "V1"],
    ("full", "brocas-area"): ["Broca's area", "broca area", "inferior frontal gyrus", "IFG"],
    ("full", "anterior-cingulate-cortex"): ["anterior cingulate", "anterior cingulat cortex"],
    ("full", "precuneus"): ["precuneus", "precunues"],
    ("full", "insula"): ["insula", "insular", "insular cortex"],
    ("full", "hippocampus"): ["hippocampus", "left hippocampus", "hipocampus"],
    ("full", "caudate-nucleus"): ["caudate", "caudate nucleus"],
    ("full", "thalamus"): ["thalamus"],
    ("full", "brainstem"): ["brainstem", "brain stem"],
    ("k5", "memory-seahorse"): ["memory seahorse", "seahorse", "hippocampus", "hipocampus"],
    ("k5", "alarm-almond"): ["alarm almond", "amygdala", "amygdla"],
    ("k5", "message-station"): ["message station", "thalamus"],
    ("k5", "hidden-island"): ["hidden island", "insula", "insular cortex", "insular"],
    ("k5", "stem"): ["stem", "brainstem", "brain stem"],
    ("k5", "movement-strip"): ["movement strip", "primary motor cortex", "precentral", "M1"],
    ("k5", "touch-strip"): ["touch strip", "postcentral gyrus", "postcentral", "S1"],
    ("k5", "frontal-lobe"): ["frontal lobe", "frontal", "front lobe", "Frontal (right)"],
    ("k5", "parietal-lobe"): ["parietal lobe", "parietal", "top of the brain"],
    ("k5", "temporal-lobe"): ["temporal lobe", "temporal", "left side lobe"],
    ("k5", "occipital-lobe"): ["occipital lobe", "occipital", "seeing lobe"],
}

SHIPPED_REJECTED: dict[tuple[TagSetName, str], list[str]] = {
    ("full", "brocas-area"): [
        "pars orbitalis",  # the third part of the inferior frontal gyrus, not Broca's
        "left pars orbitalis",
        "pars orbitalus",
        "lateral orbitofrontal cortex",
        "frontal",
    ],
    ("full", "superior-frontal-gyrus"): ["frontal", "frontal pole", "superior", "gyrus"],
    ("full", "middle-frontal-gyrus"): ["frontal", "middle temporal gyrus", "middle"],
    ("full", "precentral-gyrus"): [
        "paracentral",
        "paracentral lobule",
        "paacentral",  # one typo of the paracentral lobule, two of "precentral"
        "right precentral",
        "postcentral",
    ],
    ("full", "precuneus"): [
        "cuneus",
        "pcuneus",  # one typo of "cuneus", two of "precuneus": the cuneus's
        "superior parietal lobule",
    ],
    ("full", "anterior-cingulate-cortex"): [
        "posterior cingulate cortex",  # three edits, as many as the name forgives
        "posterior cingulate",
        "bosterior cingulate cortex",
        "isthmus cingulate",
        "cingulate",
    ],
    ("full", "fusiform-gyrus"): ["lingual gyrus", "lingual", "lateral occipital cortex"],
    ("full", "pericalcarine-cortex"): ["cuneus", "lingual gyrus", "lateral occipital"],
    ("full", "superior-temporal-gyrus"): [
        "inferior temporal gyrus",
        "inferior temporal",
        "middle temporal",
        "banks of the superior temporal sulcus",
        "temporal pole",
        "temporal",
    ],
    ("full", "hippocampus"): ["memory seahorse", "seahorse", "parahippocampal"],
    ("full", "insula"): ["hidden island", "island"],
    ("k5", "memory-seahorse"): ["amygdala", "almond", "hippocampus right side lobe"],
    ("k5", "hidden-island"): ["caudate nucleus", "putamen", "globus pallidus"],
    ("k5", "alarm-almond"): ["hippocampus", "nucleus accumbens", "accumbens"],
    ("k5", "temporal-lobe"): ["posterior cingulate", "frontal", "frontal pole"],
    ("k5", "stem"): ["thalamus", "brain", "cingulate"],
    ("k5", "movement-strip"): [
        "touch strip",
        "postcentral",
        "S1",
        "paracentral",  # part of the K-5 frontal lobe: two edits from "precentral"
        "paracentral lobule",
    ],
    ("k5", "frontal-lobe"): [
        "temporal",
        "parietal",
        "cingulate",
        "caudate",
        "superior frontal gyrus",  # a part of it, not its name
        "precentral gyrus",  # the movement strip's
    ],
}


def shipped_key(tag_set: TagSetName) -> AnswerKey:
    return {"full": FULL, "k5": K5}[tag_set].key


def shipped_cases(table: dict[tuple[TagSetName, str], list[str]]) -> list[tuple[str, str, str]]:
    return [
        (tag_set, rid, answer) for (tag_set, rid), answers in table.items() for answer in answers
    ]


@pytest.mark.parametrize(("tag_set", "region_id", "answer"), shipped_cases(SHIPPED_ACCEPTED))
def test_shipped_accepted(tag_set: TagSetName, region_id: str, answer: str) -> None:
    key = shipped_key(tag_set)
    assert key.judge(region_id, answer)
    assert key.best(answer) == region_id
    assert key.competitor(answer) is None


@pytest.mark.parametrize(("tag_set", "region_id", "answer"), shipped_cases(SHIPPED_REJECTED))
def test_shipped_rejected(tag_set: TagSetName, region_id: str, answer: str) -> None:
    key = shipped_key(tag_set)
    assert not key.judge(region_id, answer)
    assert key.best(answer) != region_id


def test_every_shipped_table_region_exists() -> None:
    for tag_set, region_id in [*SHIPPED_ACCEPTED, *SHIPPED_REJECTED]:
        assert region_id in {"full": FULL, "k5": K5}[tag_set].ids, (tag_set, region_id)
    assert {rid for tag_set, rid in SHIPPED_ACCEPTED if tag_set == "k5"} == set(K5.ids)


@pytest.mark.parametrize(
    ("tag_set", "answer", "expected"),
    [
        ("full", "pars orbitalis", "Pars orbitalis"),
        ("full", "lingual", "Lingual gyrus"),
        ("full", "pcuneus", "Cuneus"),
        ("full", "rostral anterior cingulate", None),  # in the quiz's ACC: no competitor
        ("full", "precentral gyrus", None),
        ("k5", "caudate", "Caudate nucleus"),
        ("k5", "posterior cingulate", "Posterior cingulate cortex"),
        ("k5", "pars orbitalis", None),  # part of the K-5 frontal lobe
    ],
)
def test_shipped_competitors(tag_set: TagSetName, answer: str, expected: str | None) -> None:
    assert shipped_key(tag_set).competitor(answer) == expected


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


@EACH_WORLD
@given(st.data())
def test_every_exact_form_is_accepted_however_spelled(world: World, data: st.DataObject) -> None:
    rid, form, is_abbreviation = data.draw(st.sampled_from(world.every_form))
    answer = data.draw(spelled(form, shuffle=not is_abbreviation))
    hemisphere = world.by_id[rid].hemisphere
    side_words = SIDES["left"] + SIDES["right"] if hemisphere == "both" else SIDES[hemisphere]
    side = data.draw(st.none() | st.sampled_from(side_words))
    if side is not None:
        answer = data.draw(st.sampled_from([f"{side} {answer}", f"{answer} {side}"]))
    assert world.key.judge(rid, answer), answer
    assert world.key.best(answer) == rid


@EACH_WORLD
def test_no_other_regions_name_nor_a_competitor_is_ever_accepted(world: World) -> None:
    for region_id in world.ids:
        for owner, form in [*world.wrong_names, *world.part_names]:
            if owner == region_id:
                continue
            for answer in (form, form.upper(), f"the {form.lower()}"):
                assert not world.key.judge(region_id, answer), (region_id, answer)


@EACH_WORLD
def test_a_part_names_its_region_or_nothing(world: World) -> None:
    """A part is its region's if it is one of its names (or as near one as a typo:
    the K-5 frontal lobe's frontal pole), never another region's nor a competitor."""
    for owner, part in world.part_names:
        if ordered(name_words(part)) in {ordered(name_words(n)) for n in names(world.by_id[owner])}:
            assert world.key.judge(owner, part), part
        assert world.key.best(part) in (owner, None), part
        assert world.key.competitor(part) is None, part


@EACH_WORLD
@given(st.data())
def test_no_other_regions_name_nor_a_competitor_is_accepted_however_spelled(
    world: World, data: st.DataObject
) -> None:
    owner, form = data.draw(st.sampled_from(world.wrong_names))
    region_id = data.draw(st.sampled_from(world.ids))
    is_abbreviation = owner is not None and form in world.by_id[owner].abbreviations
    answer = data.draw(spelled(form, shuffle=not is_abbreviation))
    assert world.key.judge(region_id, answer) == (region_id == owner)
    if owner is None:
        assert world.key.best(answer) is None
        assert world.key.competitor(answer) == form


def words_of(text: str) -> list[str]:
    return re.sub(r"[^a-z0-9]+", " ", text.lower()).split()


FILLERS = {"the", "a", "an", "of", "area", "region"}


def name_words(text: str) -> list[str]:
    """A name's words without filler words (the names here have no side words)."""
    words = words_of(text)
    return [w for w in words if w not in FILLERS] or words


def short_words(text: str) -> list[str] | None:
    words = name_words(text)
    kept = [w for w in words if w not in HEAD_NOUNS]
    return kept if kept and len(kept) < len(words) else None


def ordered(words: list[str]) -> str:
    return " ".join(sorted(words))


def shortened_forms(world: World) -> list[tuple[str, str, bool]]:
    """(region id, a name without its head noun, whether that is unambiguous): no
    other region or competitor is called that or shortens to it. (No two entries of
    these worlds share a name, so sharing needs no case here.)"""
    owners: list[tuple[str | None, list[str], str | None]] = [
        *((r.id, names(r), None) for r in world.regions),
        *((None, [c], None) for c in world.competitors),
        *((None, [part], rid) for rid, part in world.part_names),  # (..., part of)
    ]
    claims: dict[str, set[int]] = {}
    for number, (_, texts, _) in enumerate(owners):
        for text in texts:
            claims.setdefault(ordered(name_words(text)), set()).add(number)
            short = short_words(text)
            if short is not None:
                claims.setdefault(ordered(short), set()).add(number)
    out = []
    for number, (rid, texts, _) in enumerate(owners):
        own_parts = {n for n, (_, _, whole) in enumerate(owners) if whole == rid}
        fulls = {ordered(name_words(t)) for t in texts}
        for text in texts:
            short = short_words(text)
            if rid is not None and short is not None and ordered(short) not in fulls:
                unambiguous = claims[ordered(short)] - own_parts == {number}
                out.append((rid, " ".join(short), unambiguous))
    return out


def test_the_table_has_both_kinds_of_shortened_forms() -> None:
    kinds = {unambiguous for _, _, unambiguous in shortened_forms(TABLE)}
    assert kinds == {True, False}


@EACH_WORLD
@given(st.data())
def test_a_shortened_name_is_accepted_exactly_when_unambiguous(
    world: World, data: st.DataObject
) -> None:
    rid, short, unambiguous = data.draw(st.sampled_from(shortened_forms(world)))
    answer = data.draw(spelled(short, shuffle=True))
    assert world.key.judge(rid, answer) == unambiguous, answer
    assert world.key.best(answer) == (rid if unambiguous else None)
    assert not any(world.key.judge(other, answer) for other in world.ids if other != rid)


def oracle_distance(answer: list[str], name: list[str]) -> int:
    """How close an answer is to a name with its words in any order (brute force)."""
    sorted_pair = reference_distance(" ".join(sorted(answer)), " ".join(sorted(name)))
    return min(
        sorted_pair,
        *(reference_distance(" ".join(p), " ".join(name)) for p in itertools.permutations(answer)),
    )


def rival_within(world: World, region_id: str, answer: list[str], limit: int) -> bool:
    """Whether some other region, competitor or other region's part has a name or
    abbreviation within ``limit``, or any name shortened (an ambiguous one is a rival; counting the
    unambiguous ones too only makes the oracle claim less)."""
    rivals: list[list[str]] = []
    for other in world.regions:
        for name in names(other):
            if other.id != region_id:
                rivals.append(name_words(name))
            rivals += [short] if (short := short_words(name)) else []
        if other.id != region_id:
            for abbreviation in other.abbreviations:
                compact = "".join(words_of(abbreviation))
                if reference_distance("".join(answer), compact) <= limit:
                    return True
    others_parts = [part for owner, part in world.part_names if owner != region_id]
    for competitor in [*world.competitors, *others_parts]:
        rivals.append(name_words(competitor))
        rivals += [short] if (short := short_words(competitor)) else []
    return any(
        oracle_distance(answer, rival) <= limit
        for rival in rivals
        if letters_apart(" ".join(answer), " ".join(rival)) <= limit
    )


def letters_apart(a: str, b: str) -> int:
    """A lower bound of the distance of ``a`` and ``b`` however their words are ordered
    (each edit changes at most one letter's surplus and one letter's deficit), to skip
    the brute force where it cannot matter."""
    more, fewer = Counter(a), Counter(b)
    return max((more - fewer).total(), (fewer - more).total())


def long_names(world: World) -> list[tuple[str, str]]:
    return [
        (r.id, name)
        for r in world.regions
        for name in names(r)
        if len(re.sub(r"[^a-z]", "", " ".join(name_words(name)))) >= 9
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


@EACH_WORLD
@settings(max_examples=300)
@given(st.booleans(), st.data())
def test_one_typo_in_a_long_name_is_forgiven_unless_it_nears_a_rival(
    world: World, shuffle: bool, data: st.DataObject
) -> None:
    rid, name = data.draw(st.sampled_from(long_names(world)))
    meaningful = " ".join(name_words(name))  # a typo in "of" could make it meaningful
    edited = data.draw(one_edit(meaningful))
    words = words_of(edited)
    if shuffle:
        words = data.draw(st.permutations(words))
    answer = " ".join(words)
    limit = allowed_distance(len(meaningful.replace(" ", "")))
    accepted = world.key.judge(rid, answer)
    assert accepted == (world.key.best(answer) == rid)
    if not rival_within(world, rid, name_words(answer), limit):
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
        "frontal",
        "lobe",
        "cingulate",
        "\u0301",
        "ß",
        "\x00",
        "😀",
    ]
)


@EACH_WORLD
@settings(max_examples=300)
@given(st.one_of(st.text(max_size=250), st.lists(ANSWER_PIECES, max_size=40).map(" ".join)))
def test_arbitrary_text_never_raises_and_judge_agrees_with_best(world: World, answer: str) -> None:
    best = world.key.best(answer)
    accepted = [rid for rid in world.ids if world.key.judge(rid, answer)]
    if best is None:
        assert accepted == []
    else:
        assert best in accepted
        assert world.key.competitor(answer) is None
