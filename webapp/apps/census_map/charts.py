"""A tract's charts for the phone page, drawn on the server as small inline SVGs.

SVG needs no script and no extra request and scales to the phone's width: the
320-unit-wide viewBox is drawn at least 328 px wide (a 360 px phone less the page's
margins), so text of 16 units reads at 16 px or more, as the rest of the page. A chart is left out
whole unless the reader's information class sees every value it uses, so a chart never
shows what the list of facts would hide. Labels come from editable settings and values
from imported files, so every text and attribute is escaped.
"""

from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, TypeGuard
from xml.sax.saxutils import escape, quoteattr

from webapp.apps.census_map.dataset import Chart, DataSet, Tract, Value, format_value

WIDTH = 320
MARGIN = 8
INNER = WIDTH - 2 * MARGIN
HEADING, BODY = 18, 16  # font sizes in viewBox units; notes are muted, never smaller
LINE_HEIGHT = 1.35
GLYPH_WIDTH = 0.58  # a generous average glyph width of system-ui, in ems, for wrapping
BAR_HEIGHT = 28
SWATCH = 14
# A dark card like the phone page around it; its own background keeps the contrast
# whatever the page behind does. TEXT and MUTED are >= 4.5:1 against it.
BACKGROUND = "#1a2133"
TEXT = "#e8ecf4"
MUTED = "#b8c0d0"
TRACK = "#2b3654"
# Okabe-Ito (colour-blind friendly) without its black, which would vanish on the dark
# card; every colour is >= 3:1 against BACKGROUND.
PALETTE = ("#E69F00", "#56B4E9", "#009E73", "#F0E442", "#0072B2", "#D55E00", "#CC79A7")
MARKER, BOX_EDGE = PALETTE[0], PALETTE[1]
# Characters XML 1.0 cannot hold at all, not even escaped (imported column names might).
NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


@dataclass(frozen=True)
class Spread:
    """How one value spreads over a data set's tracts: range, quartiles and median."""

    low: float
    q1: float
    median: float
    q3: float
    high: float

    @classmethod
    def of(cls, values: Sequence[float]) -> Spread | None:
        ordered = sorted(values)
        if not ordered:
            return None
        return cls(
            ordered[0],
            _quantile(ordered, 0.25),
            _quantile(ordered, 0.5),
            _quantile(ordered, 0.75),
            ordered[-1],
        )


class ChartStats:
    """Spreads computed once per (data set id, key) and kept: a saved data set never
    changes, and sorting every tract on each page view would be waste. The caller owns
    one (per app), so nothing is shared behind its back."""

    def __init__(self) -> None:
        self._spreads: dict[tuple[int, str], Spread | None] = {}

    def spread(self, dataset: DataSet, key: str) -> Spread | None:
        """``key`` over all tracts of ``dataset``; None when no tract has a value."""
        slot = (dataset.id, key)
        if slot not in self._spreads:
            values = [t.values.get(key) for t in dataset.tracts]
            self._spreads[slot] = Spread.of([v for v in values if _finite(v)])
        return self._spreads[slot]


def charts_for(dataset: DataSet, tract: Tract, info_class: int, stats: ChartStats) -> list[str]:
    """The SVG of each chart whose every value a reader of ``info_class`` may see, in
    settings order; a chart using even one value above the class is left out."""
    visible = {a.key for a in dataset.settings.visible(info_class)}
    svgs = []
    for index, chart in enumerate(dataset.settings.charts):
        if not chart.keys_used() <= visible:
            continue
        canvas = _Canvas(f"census-chart-{index}", chart.title)
        if chart.kind == "parts":
            _draw_parts(canvas, dataset, tract, chart)
        else:
            _draw_compare(canvas, dataset, tract, chart, stats)
        svgs.append(canvas.svg())
    return svgs


class _Canvas:
    """SVG elements stacked top to bottom (``y`` is where the next one goes) and the
    same text as sentences for screen readers, which see an SVG with role=img only
    through its title and description."""

    def __init__(self, id_prefix: str, title: str) -> None:
        self.id_prefix = id_prefix
        self.title = title
        self.elements: list[str] = []
        self.spoken: list[str] = []
        self.y = 4.0
        self.add(self.lines(title, HEADING, bold=True, spoken=False))

    def lines(
        self,
        text: str,
        size: int,
        *,
        x: float = MARGIN,
        fill: str = TEXT,
        bold: bool = False,
        spoken: bool = True,
    ) -> str:
        """``text`` wrapped to the width right of ``x``, one <text> a line."""
        if spoken:
            self.spoken.append(text)
        per_line = int((WIDTH - MARGIN - x) / (GLYPH_WIDTH * size))
        weight = ' font-weight="bold"' if bold else ""
        out = []
        for line in textwrap.wrap(text, per_line):
            out.append(
                f'<text x="{_num(x)}" y="{_num(self.y + size)}" font-size="{size}" '
                f'fill="{fill}"{weight}>{_escape(line)}</text>'
            )
            self.y += size * LINE_HEIGHT
        return "".join(out)

    def ends(self, left: str, right: str, size: int) -> str:
        """Two short texts at the left and the right edge: on one line when they fit
        with a gap between them, else the right one on the next line."""
        self.spoken += [left, right]
        fits = (len(left) + len(right) + 2) * GLYPH_WIDTH * size <= INNER
        baseline = self.y + size
        self.y += size * LINE_HEIGHT * (1 if fits else 2)
        second = baseline if fits else baseline + size * LINE_HEIGHT
        return (
            f'<text x="{MARGIN}" y="{_num(baseline)}" font-size="{size}" fill="{MUTED}">'
            f"{_escape(left)}</text>"
            f'<text x="{WIDTH - MARGIN}" y="{_num(second)}" font-size="{size}" fill="{MUTED}" '
            f'text-anchor="end">{_escape(right)}</text>'
        )

    def note(self, text: str) -> None:
        self.add(self.lines(text, BODY, fill=MUTED))

    def add(self, *markup: str, keys: Sequence[str] = ()) -> None:
        """Add ``markup``, marked with the attribute keys whose values it shows."""
        if keys:
            self.elements.append(f"<g data-key={_attr(' '.join(keys))}>{''.join(markup)}</g>")
        else:
            self.elements.extend(markup)

    def svg(self) -> str:
        height = math.ceil(self.y + MARGIN)
        title_id, desc_id = f"{self.id_prefix}-title", f"{self.id_prefix}-desc"
        return (
            f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {WIDTH} {height}" '
            f'width="100%" role="img" aria-labelledby="{title_id}" '
            f'aria-describedby="{desc_id}" font-family="system-ui, sans-serif">'
            f'<title id="{title_id}">{_escape(self.title)}</title>'
            f'<desc id="{desc_id}">{_escape(". ".join(self.spoken))}</desc>'
            f'<rect width="{WIDTH}" height="{height}" rx="8" fill="{BACKGROUND}"/>'
            f"{''.join(self.elements)}</svg>"
        )


def _draw_parts(canvas: _Canvas, dataset: DataSet, tract: Tract, chart: Chart) -> None:
    """A 100% bar of the parts' shares of the total, then a row for each part."""
    assert chart.total is not None  # Chart's validation: a parts chart has a total
    total_attribute = dataset.settings.attribute(chart.total)
    total = _count(tract, [chart.total])
    canvas.add(
        canvas.lines(
            f"{total_attribute.label}: {format_value(total_attribute, total)}", BODY, fill=MUTED
        ),
        keys=[chart.total],
    )
    keyed = [(i, _count(tract, part.keys)) for i, part in enumerate(chart.parts) if part.keys]
    known = {i: count for i, count in keyed if count is not None}
    if total is None or len(known) < len(keyed):
        canvas.note("Not available for this tract.")
        return
    if total == 0:
        canvas.note("No people counted.")
        return
    # A part without keys is the rest: what the other parts leave of the total.
    rest = max(0.0, total - sum(known.values()))
    rest_keys = [chart.total, *(key for part in chart.parts for key in part.keys)]
    rows = [
        (part.label, known.get(i, rest), part.keys or rest_keys)
        for i, part in enumerate(chart.parts)
    ]
    # Census parts may overlap (Hispanic people are also counted in a race), and shares
    # of the total would then add up to more than the bar.
    parts_sum = sum(value for _, value, _ in rows)
    overlap = parts_sum > total
    whole = parts_sum if overlap else total

    top = canvas.y + 4
    bar = [
        f'<rect x="{MARGIN}" y="{_num(top)}" width="{INNER}" height="{BAR_HEIGHT}" '
        f'fill="{TRACK}" stroke="{MUTED}"/>'
    ]
    x = float(MARGIN)
    for index, (_, value, keys) in enumerate(rows):
        width = INNER * value / whole
        if width > 0:
            bar.append(
                f'<rect data-key={_attr(" ".join(keys))} x="{_num(x)}" y="{_num(top)}" '
                f'width="{_num(width)}" height="{BAR_HEIGHT}" fill="{_colour(index)}" '
                f'stroke="{BACKGROUND}"/>'
            )
        x += width
    canvas.add(*bar)
    canvas.y = top + BAR_HEIGHT + 10

    for index, (label, value, keys) in enumerate(rows):
        swatch = (
            f'<rect x="{MARGIN}" y="{_num(canvas.y + 2)}" width="{SWATCH}" height="{SWATCH}" '
            f'fill="{_colour(index)}"/>'
        )
        text = f"{label} · {format_value(total_attribute, value)} · {value / whole:.1%}"
        canvas.add(swatch, canvas.lines(text, BODY, x=MARGIN + SWATCH + 8), keys=keys)
        canvas.y += 4
    if overlap:
        canvas.note("Shares of the parts shown: they overlap, adding up to more than the total.")


def _draw_compare(
    canvas: _Canvas, dataset: DataSet, tract: Tract, chart: Chart, stats: ChartStats
) -> None:
    """Each value against its spread over all tracts: lowest to highest as a line, the
    middle half as a box, the median as a tick and this tract as a dot."""
    drawn = False
    for key in chart.keys:
        attribute = dataset.settings.attribute(key)
        spread = stats.spread(dataset, key)
        markup = [canvas.lines(attribute.label, BODY, bold=True)]
        if spread is None:
            markup.append(canvas.lines("Not available for any tract.", BODY, fill=MUTED))
        else:
            drawn = True
            value = tract.values.get(key)
            shown = value if _finite(value) else None
            markup.append(_spread_row(canvas, spread, shown))
            markup.append(
                canvas.ends(
                    f"lowest {format_value(attribute, spread.low)}",
                    f"highest {format_value(attribute, spread.high)}",
                    BODY,
                )
            )
            canvas.spoken.append(
                f"Middle half of all tracts: {format_value(attribute, spread.q1)} "
                f"to {format_value(attribute, spread.q3)}"
            )
            markup.append(_legend(canvas, "dot", f"This tract: {format_value(attribute, shown)}"))
            median = format_value(attribute, spread.median)
            markup.append(_legend(canvas, "tick", f"Median of all tracts: {median}"))
        canvas.add(*markup, keys=[key])
        canvas.y += 10
    if drawn:
        canvas.note("The box spans the middle half of all tracts, the line all of them.")


def _legend(canvas: _Canvas, symbol: Literal["dot", "tick"], text: str) -> str:
    """A line of text after the symbol it explains, as drawn on the spread row."""
    x, middle = MARGIN + 6, canvas.y + BODY * 0.65
    if symbol == "dot":
        mark = f'<circle cx="{x}" cy="{_num(middle)}" r="6" fill="{MARKER}"/>'
    else:
        mark = (
            f'<line x1="{x}" y1="{_num(middle - 8)}" x2="{x}" y2="{_num(middle + 8)}" '
            f'stroke="{TEXT}" stroke-width="3"/>'
        )
    return mark + canvas.lines(text, BODY, x=MARGIN + 18)


def _spread_row(canvas: _Canvas, spread: Spread, value: float | None) -> str:
    """Line, box, median tick and (when known) this tract's dot, on one scale."""
    left, right = MARGIN + 8, WIDTH - MARGIN - 8

    def at(number: float) -> float:
        if spread.high == spread.low:
            return (left + right) / 2
        return left + (right - left) * (number - spread.low) / (spread.high - spread.low)

    middle = canvas.y + 16
    canvas.y = middle + 16
    row = [
        f'<line x1="{_num(at(spread.low))}" y1="{_num(middle)}" x2="{_num(at(spread.high))}" '
        f'y2="{_num(middle)}" stroke="{MUTED}" stroke-width="2"/>',
        f'<rect x="{_num(at(spread.q1))}" y="{_num(middle - 9)}" '
        f'width="{_num(at(spread.q3) - at(spread.q1))}" height="18" fill="{TRACK}" '
        f'stroke="{BOX_EDGE}" stroke-width="2"/>',
        f'<line class="median" x1="{_num(at(spread.median))}" y1="{_num(middle - 13)}" '
        f'x2="{_num(at(spread.median))}" y2="{_num(middle + 13)}" stroke="{TEXT}" '
        f'stroke-width="3"/>',
    ]
    if value is not None:
        row.append(
            f'<circle class="tract" cx="{_num(at(value))}" cy="{_num(middle)}" r="7" '
            f'fill="{MARKER}" stroke="{BACKGROUND}" stroke-width="2"/>'
        )
    return "".join(row)


def _count(tract: Tract, keys: Sequence[str]) -> float | None:
    """The sum of ``keys`` for ``tract``; None if any is missing or not a count."""
    values = [tract.values.get(key) for key in keys]
    counts = [v for v in values if _finite(v) and v >= 0]
    return sum(counts) if len(counts) == len(values) else None


def _quantile(ordered: Sequence[float], fraction: float) -> float:
    """Linear interpolation between the closest ranks (numpy's default method)."""
    position = fraction * (len(ordered) - 1)
    below = math.floor(position)
    above = min(below + 1, len(ordered) - 1)
    return ordered[below] + (ordered[above] - ordered[below]) * (position - below)


def _finite(value: Value) -> TypeGuard[float]:
    return value is not None and math.isfinite(value)


def _colour(index: int) -> str:
    return PALETTE[index % len(PALETTE)]


def _num(number: float) -> str:
    return f"{number:.1f}".removesuffix(".0")


def _escape(text: str) -> str:
    return escape(NOT_XML.sub("", text))


def _attr(text: str) -> str:
    return quoteattr(NOT_XML.sub("", text))
