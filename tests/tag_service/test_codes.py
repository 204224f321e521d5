"""Codes: random, canonical upper case, payloads in QR alphanumeric mode, full QR only."""

import re

import pytest
import segno

from tag_service.codes import (
    CODE_LENGTH,
    Contact,
    PayloadError,
    content_hash,
    make_symbol,
    matrix_rows,
    modules_across,
    new_code,
    normalize_code,
    render_png,
    render_svg,
    symbol_variants,
    tel_payload,
    text_payload,
    url_payload,
    vcard_payload,
)


def test_codes_are_random_and_carry_at_least_30_bits() -> None:
    codes = {new_code() for _ in range(2000)}
    assert len(codes) == 2000
    assert all(re.fullmatch(r"[0-9A-Z]+", code) for code in codes)
    assert 36**CODE_LENGTH >= 2**30
    assert sorted(codes) != [c for c in codes]  # not issued in order


@pytest.mark.parametrize("text", ["abc12xy", "ABC12XY", "AbC12xY"])
def test_codes_resolve_case_insensitively(text: str) -> None:
    assert normalize_code(text) == "ABC12XY"


@pytest.mark.parametrize("text", ["", "ABC12X", "ABC12XYZ", "ABC-2XY", "ÄBC12XY", "x" * 10_000])
def test_malformed_codes_are_refused(text: str) -> None:
    assert normalize_code(text) is None


def test_url_payload_is_upper_case_alphanumeric_and_version_2() -> None:
    payload = url_payload("http://192.168.100.200:8000", "7K2Q9XA")
    assert payload == "HTTP://192.168.100.200:8000/T/7K2Q9XA"
    symbol = make_symbol(payload)
    assert symbol.mode == "alphanumeric"
    assert symbol.version == 2
    assert not symbol.is_micro
    lower = segno.make_qr(payload.lower(), error="m")
    assert lower.version == 3  # what upper case saves


def test_direct_payloads() -> None:
    assert text_payload("  Room 101  ") == "Room 101"
    assert tel_payload("+1 (555) 123-4567") == "tel:+15551234567"
    card = vcard_payload(Contact(name="Ada Lovelace", phone="+441234", email="ada@example.org"))
    assert card.startswith("BEGIN:VCARD") and "Ada Lovelace" in card and "ada@example.org" in card


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: text_payload(""), "needs some text"),
        (lambda: text_payload("x" * 501), "at most"),
        (lambda: text_payload("Grüße"), "ASCII"),
        (lambda: tel_payload("call me"), "not a phone number"),
        (lambda: vcard_payload(Contact(name=" ")), "needs a name"),
    ],
)
def test_bad_payloads_are_refused_with_the_reason(make: object, message: str) -> None:
    with pytest.raises(PayloadError, match=message):
        make()  # type: ignore[operator]


def test_level_l_is_offered_only_when_smaller() -> None:
    assert [s.error for s in symbol_variants("HTTP://10.0.0.1:8000/T/ABCDEFG")] == ["M"]
    long_text = "A" * 60  # 60 alphanumeric: version 3-M, but 2-L... or smaller at L
    variants = symbol_variants(long_text)
    assert variants[0].error in ("M", "Q", "H")
    if len(variants) == 2:
        assert variants[1].error == "L"
        assert modules_across(variants[1]) < modules_across(variants[0])


def test_matrix_rows_exclude_the_quiet_zone() -> None:
    symbol = make_symbol("HTTP://10.0.0.1:8000/T/ABCDEFG")
    rows = matrix_rows(symbol)
    assert len(rows) == len(rows[0]) == 25
    assert rows[0].startswith("1111111")  # finder pattern
    assert modules_across(symbol) == 33


def test_svg_has_crisp_edges_and_a_white_quiet_zone() -> None:
    svg = render_svg(make_symbol("HELLO")).decode()
    assert 'shape-rendering="crispEdges"' in svg
    assert 'fill="#fff"' in svg
    assert "<script" not in svg


def test_png_and_content_hash() -> None:
    png = render_png(make_symbol("HELLO"), scale=4)
    assert png.startswith(b"\x89PNG")
    assert content_hash("HELLO", "M") == content_hash("HELLO", "M")
    assert content_hash("HELLO", "M") != content_hash("HELLO", "L")
