"""Short codes, the payloads they carry and the QR symbols that show them.

A URL tag carries ``HTTP://HOST:PORT/T/CODE`` in upper case: digits, upper-case
letters and ``$%*+-./:`` are QR alphanumeric mode, which packs 5.5 bits per
character instead of 8, so a typical LAN URL fits version 2 instead of 3 and every
module is bigger at the same size. Codes are always full QR symbols (phone cameras
do not read Micro QR), at error level M, or L when that makes the symbol smaller.
"""

from __future__ import annotations

import hashlib
import io
import re
import secrets
import string
from dataclasses import dataclass
from typing import Literal

import segno
import segno.helpers

from tag_service.sizing import QUIET_ZONE_MODULES, symbol_modules

ALPHABET = string.digits + string.ascii_uppercase
CODE_LENGTH = 7  # 36**7 is about 7.8e10: 36 bits, guessing one takes ~4e10 tries
_CODE = re.compile(rf"[0-9A-Z]{{{CODE_LENGTH}}}")
_PHONE = re.compile(r"\+?[0-9][0-9 ()./-]{2,30}")

PayloadKind = Literal["url", "text", "vcard", "tel"]
PAYLOAD_KINDS: tuple[PayloadKind, ...] = ("url", "text", "vcard", "tel")
ErrorLevel = Literal["M", "L"]
MAX_TEXT_CHARS = 500


class PayloadError(ValueError):
    """A payload a QR tag cannot carry (empty, too long, not ASCII, malformed)."""


def new_code() -> str:
    """A random code: unguessable and non-sequential, so codes reveal nothing."""
    return "".join(secrets.choice(ALPHABET) for _ in range(CODE_LENGTH))


def normalize_code(text: str) -> str | None:
    """``text`` as a code in canonical (upper) case, or None when it cannot be one."""
    if len(text) != CODE_LENGTH:
        return None
    upper = text.upper()
    return upper if _CODE.fullmatch(upper) else None


def url_payload(base_url: str, code: str, route: str = "T") -> str:
    """The URL a code resolves through (``/T/`` for tags, ``/P/`` for pairing),
    upper-cased for alphanumeric mode."""
    return _ascii(f"{base_url.rstrip('/')}/{route}/{code}".upper())


def text_payload(text: str) -> str:
    text = text.strip()
    if not text:
        raise PayloadError("a text tag needs some text")
    if len(text) > MAX_TEXT_CHARS:
        raise PayloadError(f"a text tag holds at most {MAX_TEXT_CHARS} characters")
    return _ascii(text)


def tel_payload(number: str) -> str:
    """A dialer tag: phones offer to call the number."""
    number = number.strip()
    if not _PHONE.fullmatch(number):
        raise PayloadError(f"{number!r} is not a phone number (digits, spaces, +, -, ( ))")
    return "tel:" + re.sub(r"[ ().-]", "", number)


@dataclass(frozen=True)
class Contact:
    """What a vCard tag carries: phones offer to save the contact."""

    name: str
    phone: str | None = None
    email: str | None = None
    organization: str | None = None
    url: str | None = None


def vcard_payload(contact: Contact) -> str:
    if not contact.name.strip():
        raise PayloadError("a contact tag needs a name")
    data = segno.helpers.make_vcard_data(
        name=contact.name.strip(),
        displayname=contact.name.strip(),
        phone=contact.phone,
        email=contact.email,
        org=contact.organization,
        url=contact.url,
    )
    return _ascii(data)


def _ascii(payload: str) -> str:
    if not payload.isascii():
        raise PayloadError("codes carry ASCII only (some phone readers garble other text)")
    return payload


def make_symbol(payload: str, error: ErrorLevel = "M") -> segno.QRCode:
    """A full QR symbol (never Micro QR) for ``payload``."""
    return segno.make_qr(payload, error=error.lower())


def symbol_variants(payload: str) -> tuple[segno.QRCode, ...]:
    """Level M, then level L when it is smaller: what placement may try, in order."""
    medium = make_symbol(payload, "M")
    # The L symbol's size does not depend on its mask: size it with a fixed mask (choosing
    # one scores all eight) and build the real symbol only when it is smaller.
    low_size = segno.make_qr(payload, error="l", mask=0).symbol_size(border=0)[0]
    if low_size < medium.symbol_size(border=0)[0]:
        return (medium, make_symbol(payload, "L"))
    return (medium,)


def modules_across(symbol: segno.QRCode) -> int:
    """The symbol's width in modules, quiet zone included (what sizing works with)."""
    return symbol_modules(int(symbol.symbol_size(border=0)[0]))


def matrix_rows(symbol: segno.QRCode) -> list[str]:
    """The modules row by row, ``1`` dark, without the quiet zone: what tiles draw."""
    return ["".join("1" if bit else "0" for bit in row) for row in symbol.matrix]


def content_hash(payload: str, error: str) -> str:
    """A short hash naming a rendering: it changes whenever the symbol would."""
    return hashlib.sha256(f"{error}\0{payload}".encode()).hexdigest()[:16]


def render_svg(symbol: segno.QRCode) -> bytes:
    """A scalable SVG with a white quiet zone and crisp (unsmoothed) module edges."""
    buffer = io.BytesIO()
    symbol.save(
        buffer,
        kind="svg",
        border=QUIET_ZONE_MODULES,
        xmldecl=False,
        omitsize=True,
        light="#fff",
        dark="#000",
        nl=False,
    )
    return buffer.getvalue().replace(b"<svg ", b'<svg shape-rendering="crispEdges" ', 1)


def render_png(symbol: segno.QRCode, scale: int) -> bytes:
    """A PNG with ``scale`` pixels per module (for print or a phone screen)."""
    buffer = io.BytesIO()
    symbol.save(buffer, kind="png", border=QUIET_ZONE_MODULES, scale=scale, light="#fff")
    return buffer.getvalue()
