"""Downloads: the one rule for the name a file gets on the instructor's disk."""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable

_NOT_SLUG = re.compile(r"[^a-z0-9]+")
MAX_FILE_NAME = 120


def file_slug(text: str) -> str:
    """``text`` as a safe file-name part: ASCII letters and digits joined by ``-``
    (accents folded, everything else dropped)."""
    ascii_text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    return _NOT_SLUG.sub("-", ascii_text.lower()).strip("-")


def _unrepeated(slugs: list[str]) -> list[str]:
    """``slugs`` without those another one says already, word for word (a wall's id in
    a class title naming the wall, a day in a title naming the date); of two alike, the
    first stays."""
    return [
        slug
        for i, slug in enumerate(slugs)
        if not any(
            f"-{slug}-" in f"-{other}-" and (other != slug or j < i)
            for j, other in enumerate(slugs)
            if j != i
        )
    ]


def attachment(parts: Iterable[str], suffix: str) -> str:
    """A ``Content-Disposition`` value saving the download as ``parts`` joined, each
    made a slug (empty ones, and those another part says already, left out), bounded,
    with ``suffix``: nothing a person typed (a class title) can break the header or
    choose a path."""
    stem = "-".join(_unrepeated([slug for part in parts if (slug := file_slug(part))]))
    return f'attachment; filename="{stem[:MAX_FILE_NAME].strip("-") or "download"}{suffix}"'
