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


def attachment(parts: Iterable[str], suffix: str) -> str:
    """A ``Content-Disposition`` value saving the download as ``parts`` joined, each
    made a slug (empty ones left out), bounded, with ``suffix``: nothing a person
    typed (a class title) can break the header or choose a path."""
    stem = "-".join(slug for part in parts if (slug := file_slug(part)))
    return f'attachment; filename="{stem[:MAX_FILE_NAME].strip("-") or "download"}{suffix}"'
