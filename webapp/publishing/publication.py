"""What a phone publishes: a title and plain blocks, never HTML.

Apps describe content as a :class:`Publication`; the server renders it with an
autoescaping template, so nothing anyone typed can become markup or script on the wall.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Literal

from jinja2 import Environment
from pydantic import BaseModel, ConfigDict, Field, field_validator


class Block(BaseModel):
    """One part of a publication: a paragraph, Markdown text (rendered without raw
    HTML), a table of facts, a site image, or a chart.

    A chart is SVG an app drew on the server from its own data, escaping every text
    in it (as the census map's charts do); it is the one block shown as markup, and
    only an app's code, never a request, makes blocks."""

    model_config = ConfigDict(extra="forbid")

    kind: Literal["text", "markdown", "facts", "image", "chart"]
    text: str = Field(default="", max_length=8_000)
    rows: list[tuple[str, str]] = Field(default_factory=list, max_length=100)
    src: str = Field(default="", max_length=500)
    svg: str = Field(default="", max_length=50_000)

    @field_validator("svg")
    @classmethod
    def _one_svg(cls, value: str) -> str:
        if value and not (value.startswith("<svg ") and value.endswith("</svg>")):
            raise ValueError("a chart is one SVG element")
        if "<script" in value.lower() or "<foreignobject" in value.lower():
            raise ValueError("a chart holds no script and no foreign content")
        return value

    @field_validator("src")
    @classmethod
    def _same_site(cls, value: str) -> str:
        if value and (not value.startswith("/") or value.startswith("//")):
            raise ValueError("images come from this site only (a path starting with /)")
        return value


class Publication(BaseModel):
    """What a phone content page offers to the public screen."""

    model_config = ConfigDict(extra="forbid")

    title: str = Field(min_length=1, max_length=200)
    blocks: list[Block] = Field(default_factory=list, max_length=50)


def render_item(templates: Environment, publication: Publication, author: str, at_ms: int) -> str:
    """The publication as the public screen shows it: escaped, server-rendered HTML."""
    when = datetime.fromtimestamp(at_ms / 1000, UTC)
    return templates.get_template("public_item.html").render(
        item=publication, author=author, when=when.strftime("%H:%M UTC, %d %b %Y")
    )
