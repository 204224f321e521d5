"""Markdown for texts people edit (tutor pages): CommonMark with raw HTML off, so a
text can format itself but never inject markup; links are the only way out."""

from __future__ import annotations

from functools import cache

from markdown_it import MarkdownIt
from markupsafe import Markup


@cache
def _parser() -> MarkdownIt:
    return MarkdownIt("commonmark", {"html": False}).enable("table")


def markdown_html(text: str) -> Markup:
    """``text`` as safe HTML (markdown-it escapes everything it does not format and
    refuses javascript:, vbscript: and data: links)."""
    return Markup(_parser().render(text))


def markdown_inline(text: str) -> Markup:
    """One line of Markdown (a citation's italic journal title) as safe inline HTML,
    without the paragraph around it."""
    return Markup(_parser().renderInline(text))
