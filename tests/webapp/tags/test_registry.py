"""The tag registry: issuing, declaring and layouts, on both backends."""

from __future__ import annotations

from typing import Any

import pytest
from pydantic import ValidationError

from tag_service.codes import ALPHABET, CODE_LENGTH, modules_across, symbol_variants, url_payload
from tests.conftest import tag_spec
from wall_client.config import load_wall
from wall_client.layout import Wall
from webapp.core.settings import CONTENT_DIR
from webapp.database.connection import Database
from webapp.database.models import TagLayoutRecord
from webapp.tags.registry import (
    LAYOUTS_KEPT,
    declare,
    find,
    get_layout,
    issue,
    layout_for,
    payload_of,
    tag_sets,
    update_tag,
    url_code_sizes,
    wall_tags,
)
from webapp.tags.schemas import TagUpdate

BASE = "http://192.168.1.20:8000"
APPS = ("quiz", "atlas")  # the made-up apps whose tags these tests place
TOL = 1e-6  # mm: float rounding of pixel edges


@pytest.fixture(scope="module")
def demo() -> Wall:
    return load_wall(CONTENT_DIR / "walls" / "demo.toml")


def test_issued_codes_are_random_short_and_upper_case(db: Database) -> None:
    codes = [issue(db, "demo", tag_spec(label=f"T{i}"), "test").code for i in range(50)]
    assert len(set(codes)) == 50
    assert all(len(code) == 7 and set(code) <= set(ALPHABET) for code in codes)
    assert codes != sorted(codes), "not sequential"
    tag = find(db, codes[0])
    assert tag is not None and payload_of(tag, BASE) == f"HTTP://192.168.1.20:8000/T/{codes[0]}"


def test_direct_payloads_are_encoded_as_given(db: Database) -> None:
    text = issue(db, "demo", tag_spec(kind="text", text="Room 101"), "test")
    tel = issue(db, "demo", tag_spec(kind="tel", number="+1 949 824 5011"), "test")
    assert payload_of(text, BASE) == "Room 101"
    assert payload_of(tel, BASE) == "tel:+19498245011"


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"anchor": None}, "either an anchor"),
        ({"screen": "menu"}, "either an anchor"),
        ({"kind": "tel", "number": "call me"}, "phone number"),
        ({"kind": "text", "text": "Grüße"}, "ASCII"),
        ({"tag_set": "no spaces"}, "String should match pattern"),
        ({"colour": "red"}, "Extra inputs are not permitted"),
        ({"anchor": None, "screen": "menu", "clear_mm": 20.0}, "clear_mm keeps the area"),
        ({"clear_mm": 0.0}, "greater than 0"),
        ({"clear_mm": -5.0}, "greater than 0"),
        ({"clear_mm": 1_001.0}, "less than or equal to 1000"),
    ],
)
def test_malformed_specs_are_refused(fields: dict[str, object], message: str) -> None:
    with pytest.raises(ValidationError, match=message):
        tag_spec(**fields)


def test_declaring_keeps_codes_and_switches_off_what_is_gone(db: Database) -> None:
    first = [tag_spec(name="a", label="A"), tag_spec(name="b", label="B")]
    declare(db, "demo", "quiz", first)
    codes = {t.name: t.code for t in wall_tags(db, "demo")}

    declare(db, "demo", "quiz", [tag_spec(name="a", label="A again")])

    tags = {t.name: t for t in wall_tags(db, "demo")}
    assert {name: t.code for name, t in tags.items()} == codes, "codes never change"
    assert tags["a"].label == "A again" and tags["a"].active
    assert not tags["b"].active, "switched off, history kept"
    with pytest.raises(ValueError, match="need a name and app 'quiz'"):
        declare(db, "demo", "quiz", [tag_spec(label="nameless")])


def test_tag_sets_are_the_named_sets(db: Database) -> None:
    issue(db, "demo", tag_spec(tag_set="k5"), "test")
    issue(db, "demo", tag_spec(tag_set="medical"), "test")
    issue(db, "demo", tag_spec(), "test")
    issue(db, "other", tag_spec(tag_set="elsewhere"), "test")
    assert tag_sets(db, "demo") == ["k5", "medical"]


def test_layouts_place_the_set_and_the_tags_of_every_set(db: Database, demo: Wall) -> None:
    always = issue(db, "demo", tag_spec(screen="registration", anchor=None), "test")
    k5 = issue(db, "demo", tag_spec(tag_set="k5"), "test")
    medical = issue(db, "demo", tag_spec(tag_set="medical"), "test")

    layout = get_layout(db, "demo", layout_for(db, demo, "k5", BASE, APPS))

    assert layout is not None
    assert {p["code"] for p in layout.placed} == {always.code, k5.code}
    placed = next(p for p in layout.placed if p["code"] == k5.code)
    assert placed["payload"] == payload_of(k5, BASE)
    assert len(placed["matrix"]) == placed["modules"] - 8, "the symbol without quiet zone"
    assert medical.code not in {p["code"] for p in layout.placed}
    assert get_layout(db, "other-wall", layout.id) is None


def test_an_unchanged_set_reuses_its_layout_and_a_change_makes_a_new_one(
    db: Database, demo: Wall
) -> None:
    tag = issue(db, "demo", tag_spec(tag_set="k5"), "test")
    first = layout_for(db, demo, "k5", BASE, APPS)
    assert layout_for(db, demo, "k5", BASE, APPS) == first
    update_tag(db, tag.code, TagUpdate(label="renamed"))
    second = layout_for(db, demo, "k5", BASE, APPS)
    assert second != first
    update_tag(db, tag.code, TagUpdate(active=False))
    third = get_layout(db, "demo", layout_for(db, demo, "k5", BASE, APPS))
    assert third is not None and third.placed == []


def test_old_layouts_are_pruned(db: Database, demo: Wall) -> None:
    tag = issue(db, "demo", tag_spec(tag_set="k5"), "test")
    for index in range(LAYOUTS_KEPT + 5):
        update_tag(db, tag.code, TagUpdate(label=f"v{index}"))
        layout_for(db, demo, "k5", BASE, APPS)
    with db.session() as session:
        assert session.query(TagLayoutRecord).count() == LAYOUTS_KEPT


def test_unplaceable_tags_are_kept_with_the_reason(db: Database, demo: Wall) -> None:
    issue(db, "demo", tag_spec(label="huge", size_mm=2000.0), "test")
    layout = get_layout(db, "demo", layout_for(db, demo, None, BASE, APPS))
    assert layout is not None and layout.placed == []
    [problem] = layout.unplaced
    assert problem["label"] == "huge" and problem["reason"].startswith("display too small")


def test_updating_an_unknown_tag_raises_key_error(db: Database) -> None:
    with pytest.raises(KeyError):
        update_tag(db, "NOSUCH1", TagUpdate(label="x"))


def test_a_clearance_is_stored_when_issued_or_declared(db: Database) -> None:
    issued = issue(db, "demo", tag_spec(label="pinned", clear_mm=40.0), "test")
    plain = issue(db, "demo", tag_spec(label="plain"), "test")
    declare(db, "demo", "quiz", [tag_spec(name="region", clear_mm=12.5)])
    stored = {t.label or t.name: t.clear_mm for t in wall_tags(db, "demo")}
    assert stored == {"pinned": 40.0, "plain": None, "region": 12.5}
    found = find(db, issued.code)
    assert found is not None and found.clear_mm == 40.0
    assert plain.clear_mm is None


def test_changing_the_clearance_places_the_code_again_beside_its_anchor(
    db: Database, demo: Wall
) -> None:
    ax, ay = 300.0, 300.0  # tag_spec's anchor

    def declared(clear_mm: float | None) -> tuple[int, dict[str, Any]]:
        spec = tag_spec(app="atlas", name="hippocampus", clear_mm=clear_mm)
        declare(db, "demo", "atlas", [spec])
        layout = get_layout(db, "demo", layout_for(db, demo, None, BASE, APPS))
        assert layout is not None
        [code] = layout.placed
        return layout.id, code

    first, on_it = declared(None)
    assert on_it["leader"] is None, "without a clearance the code covers its anchor"
    second, beside = declared(50.0)
    assert second != first, "a new clearance is a new layout"
    x, y, width, height = beside["rect"]
    outside = (
        x >= ax + 50.0 - TOL
        or x + width <= ax - 50.0 + TOL
        or y >= ay + 50.0 - TOL
        or y + height <= ay - 50.0 + TOL
    )
    assert outside, "wholly outside the square"
    assert beside["leader"] is not None and tuple(beside["leader"][1]) == (ax, ay)
    assert declared(50.0)[0] == second, "an unchanged clearance reuses the layout"
    assert declared(80.0)[0] != second


def test_a_tag_urls_symbol_sizes_are_encoded_once_per_base_url() -> None:
    """Pages that size their surroundings by the codes ask often; the symbols are
    encoded once (the answer is the same as encoding them again)."""
    base = "http://192.0.2.7:8000"
    payload = url_payload(base, "0" * CODE_LENGTH)
    expected = tuple(modules_across(symbol) for symbol in symbol_variants(payload))
    hits = url_code_sizes.cache_info().hits
    assert url_code_sizes(base) == expected
    assert url_code_sizes(base) == expected
    assert url_code_sizes.cache_info().hits >= hits + 1
