"""A census data set: tracts (outlines in longitude/latitude and attribute values) and
the settings that say how the map names, groups, describes and charts them.

Settings are plain TOML beside the shapes (``content/census/*.toml``) so an
instructor can edit them; everything here is pure (no database, no wall).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator
from shapely import MultiPolygon, Polygon

InfoClass = int
Value = float | None
Kind = Literal["count", "money", "number", "percent"]

# Margins of error (the American Community Survey publishes them at 90 % confidence).
# Census Reporter marks an estimate whose margin is at least 10 % of it; so do we.
LARGE_MARGIN = 0.10
MARGINS_FROM = 2  # the lowest information class that reads the margin itself ("± 312")
SHARES_FROM = 4  # ... and the margin as a share of the value ("8%")
# Where the ACS gives a median in an open-ended interval ("250,000+", "2,500-"), the
# estimate is stored as that bound and its margin slot holds which way the value lies
# (a margin is never negative, so these cannot be mistaken for one).
OPEN_ABOVE = -1.0
OPEN_BELOW = -2.0


class Attribute(BaseModel):
    """One column of the table: how to call it and who may see it."""

    model_config = ConfigDict(extra="forbid")

    key: str = Field(min_length=1, max_length=64)
    label: str = Field(min_length=1, max_length=120)
    kind: Kind = "count"
    info_class: int = Field(default=1, ge=1, le=5)  # the lowest class that sees it
    missing: list[float] = Field(default_factory=list, max_length=10)  # codes for "no value"
    margin: str | None = Field(default=None, min_length=1, max_length=64)  # its MOE's column


class Part(BaseModel):
    """A slice of a breakdown chart: the sum of ``keys``, or (no keys) what the other
    slices leave of the chart's total."""

    model_config = ConfigDict(extra="forbid")

    label: str = Field(min_length=1, max_length=60)
    keys: list[str] = Field(default_factory=list, max_length=20)


class Chart(BaseModel):
    """A chart on a tract's phone page.

    ``parts``: the shares of ``total`` taken by each part (age, ethnicity, ...).
    ``compare``: each of ``keys`` against the spread of that value over all tracts
    (housing value, income).
    """

    model_config = ConfigDict(extra="forbid")

    title: str = Field(min_length=1, max_length=80)
    kind: Literal["parts", "compare"] = "parts"
    total: str | None = None
    parts: list[Part] = Field(default_factory=list, max_length=12)
    keys: list[str] = Field(default_factory=list, max_length=8)

    @model_validator(mode="after")
    def _complete(self) -> Chart:
        if self.kind == "parts" and (self.total is None or len(self.parts) < 2):
            raise ValueError(f"chart {self.title!r}: a parts chart needs a total and two parts")
        if sum(1 for part in self.parts if not part.keys) > 1:
            raise ValueError(f"chart {self.title!r}: only one part can be the rest")
        if self.kind == "compare" and not self.keys:
            raise ValueError(f"chart {self.title!r}: a compare chart needs keys")
        return self

    def keys_used(self) -> set[str]:
        used = {key for part in self.parts for key in part.keys} | set(self.keys)
        return used | ({self.total} if self.total else set())


MOST_GROUPS = 10
"""The most groups a data set has: as many toggles as the menu screen must hold."""


class Grouping(BaseModel):
    """How tracts fall into the groups the menu toggles.

    ``number``: contiguous tract-number ranges (``ranges`` as given, else ``count``
    ranges holding similar numbers of tracts); ``county``: one group per county.
    """

    model_config = ConfigDict(extra="forbid")

    by: Literal["number", "county"] = "number"
    count: int = Field(default=MOST_GROUPS, ge=1, le=MOST_GROUPS)
    ranges: list[tuple[int, int]] | None = Field(default=None, max_length=MOST_GROUPS)


class DataSetSettings(BaseModel):
    model_config = ConfigDict(extra="forbid")

    title: str = Field(min_length=1, max_length=120)
    source: str = Field(default="", max_length=2_000)
    headline: list[str] = Field(min_length=1, max_length=4)
    attributes: list[Attribute] = Field(min_length=1)
    charts: list[Chart] = Field(default_factory=list, max_length=8)
    groups: Grouping = Field(default_factory=Grouping)
    counties: dict[str, str] = Field(default_factory=dict)  # county FIPS (5 digits) -> name
    # The text column whose values name the tracts ("Foggy Bottom"); an import reads it
    # into ``names`` (tract key -> name). Without it an import takes NAME when that is text.
    name_column: str | None = Field(default=None, min_length=1, max_length=64)
    names: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _known_keys(self) -> DataSetSettings:
        keys = [a.key for a in self.attributes]
        if len(set(keys)) != len(keys):
            raise ValueError("an attribute is listed twice")
        own = [a.key for a in self.attributes if a.margin == a.key]
        if own:
            raise ValueError(f"an attribute cannot be its own margin: {', '.join(own)}")
        unknown = (set(self.headline) | {k for c in self.charts for k in c.keys_used()}) - set(keys)
        if unknown:
            raise ValueError(f"unknown attributes named: {', '.join(sorted(unknown))}")
        private = [k for k in self.headline if self.attribute(k).info_class != 1]
        if private:
            raise ValueError(
                f"headline values show on the wall for everyone, so they need info_class 1: "
                f"{', '.join(private)}"
            )
        return self

    def attribute(self, key: str) -> Attribute:
        return next(a for a in self.attributes if a.key == key)

    def clean(self, values: dict[str, Value]) -> dict[str, Value]:
        """The values with each attribute's "no value" codes (a median of 0 where nobody
        was counted) as None."""
        missing = {a.key: a.missing for a in self.attributes if a.missing}
        return {k: None if v in missing.get(k, ()) else v for k, v in values.items()}

    def visible(self, info_class: int) -> list[Attribute]:
        """The attributes a reader of ``info_class`` sees, headline ones first."""
        shown = [self.attribute(key) for key in self.headline]
        shown += [a for a in self.attributes if a.key not in self.headline]
        return [a for a in shown if a.info_class <= info_class]


@dataclass(frozen=True)
class Tract:
    geoid: str
    label: str  # the tract number as people write it: "220.01"
    county: str  # county FIPS, or "" when the key is not a census GEOID
    shape: Polygon | MultiPolygon  # longitude/latitude
    values: dict[str, Value]
    name: str = ""  # its name in the data set's name column ("Foggy Bottom"), if any

    @property
    def base_number(self) -> int:
        """The tract number without its suffix (220 for 220.01): what groups go by."""
        return int(self.label.split(".")[0]) if self.label.split(".")[0].isdigit() else 0


@dataclass(frozen=True)
class Group:
    id: str  # a layer key of the wall state
    name: str
    geoids: frozenset[str]


@dataclass(frozen=True)
class DataSet:
    id: int
    name: str
    settings: DataSetSettings
    tracts: tuple[Tract, ...]
    groups: tuple[Group, ...] = field(init=False)
    group_of: dict[str, str] = field(init=False)

    def __post_init__(self) -> None:
        groups = tuple(make_groups(self.tracts, self.settings))
        object.__setattr__(self, "groups", groups)
        object.__setattr__(
            self, "group_of", {g: group.id for group in groups for g in group.geoids}
        )

    @property
    def title(self) -> str:
        return self.settings.title

    def tract(self, geoid: str) -> Tract | None:
        return next((t for t in self.tracts if t.geoid == geoid), None)

    def county_name(self, tract: Tract) -> str:
        return self.settings.counties.get(tract.county, tract.county)

    def tract_title(self, tract: Tract) -> str:
        """How pages, balloons and KML name a tract: "Tract 220.01, Placer"; by its name
        where the data set gives one ("Foggy Bottom", with the county's name when the
        data set names counties and the name does not)."""
        if tract.name:
            county = self.settings.counties.get(tract.county, "")
            return f"{tract.name}, {county}" if county and county not in tract.name else tract.name
        county = self.county_name(tract)
        return f"Tract {tract.label}, {county}" if county else f"Tract {tract.label}"

    def headline(self, tract: Tract) -> list[tuple[str, str]]:
        """The values a balloon shows, for everyone at the wall (and in Google Earth)."""
        shown = [
            fact(self.settings.attribute(key), tract.values, 1) for key in self.settings.headline
        ]
        return [(f.label, f.value) for f in shown]

    def facts(self, tract: Tract, info_class: int) -> list[Fact]:
        """The values a reader of ``info_class`` sees (never one above that class), with
        their margins of error as far as that class reads them."""
        return [fact(a, tract.values, info_class) for a in self.settings.visible(info_class)]


@dataclass(frozen=True)
class Fact:
    """One value as a phone page shows it."""

    label: str
    value: str  # "$52,941", "$250,000 or more", "not available"
    margin: str | None = None  # "± $4,310", for classes from MARGINS_FROM
    share: str | None = None  # "8%": the margin against the value, from SHARES_FROM
    uncertain: bool = False  # a margin of at least LARGE_MARGIN of the value (every class)

    def text(self) -> str:
        """The value, margin and mark on one line (a publication's table cell)."""
        share = f" ({self.share})" if self.share else ""
        margin = f" {self.margin}{share}" if self.margin else ""
        return f"{self.value}{margin}{' (uncertain)' if self.uncertain else ''}"


def fact(attribute: Attribute, values: dict[str, Value], info_class: int) -> Fact:
    """``attribute`` of a tract's ``values`` for a reader of ``info_class``: the one
    place that decides how a value, its margin and a bound read."""
    value = values.get(attribute.key)
    margin = values.get(attribute.margin) if attribute.margin and value is not None else None
    if value is None or margin is None:
        return Fact(attribute.label, format_value(attribute, value))
    if margin in (OPEN_ABOVE, OPEN_BELOW):
        bound = "or more" if margin == OPEN_ABOVE else "or less"
        return Fact(attribute.label, f"{format_value(attribute, value)} {bound}")
    uncertain = large_margin(value, margin)
    return Fact(
        attribute.label,
        format_value(attribute, value),
        margin=f"± {format_value(attribute, margin)}" if info_class >= MARGINS_FROM else None,
        share=f"{margin / abs(value):.0%}" if info_class >= SHARES_FROM and value else None,
        uncertain=uncertain,
    )


def large_margin(value: float, margin: float) -> bool:
    """Census Reporter's rule: a margin of at least 10 % of the value asks for care."""
    return margin >= LARGE_MARGIN * abs(value) and margin > 0


def format_value(attribute: Attribute, value: Value) -> str:
    if value is None:
        return "not available"
    if attribute.kind == "money":
        return f"${value:,.0f}"
    if attribute.kind == "count":
        return f"{value:,.0f}"
    number = f"{value:,.2f}".rstrip("0").rstrip(".")
    return f"{number}%" if attribute.kind == "percent" else number


def tract_label(geoid: str) -> str:
    """The tract number of a census GEOID (state 2 + county 3 + tract 6 digits):
    ``06067001101`` -> ``11.01``; ``06067002200`` -> ``22``. Other keys stay as they are."""
    if len(geoid) == 11 and geoid.isdigit():
        base, suffix = int(geoid[5:9]), geoid[9:]
        return f"{base}.{suffix}" if suffix != "00" else str(base)
    return geoid


def county_of(geoid: str) -> str:
    return geoid[:5] if len(geoid) == 11 and geoid.isdigit() else ""


def make_groups(tracts: Sequence[Tract], settings: DataSetSettings) -> list[Group]:
    """The data set's tract groups, in menu order; every tract is in exactly one."""
    rule = settings.groups
    if rule.by == "county":
        counties = sorted({t.county for t in tracts})
        return [
            Group(
                f"tracts-county-{county or 'none'}",  # by FIPS: unique where names may not be
                settings.counties.get(county, county or "Tracts"),
                frozenset(t.geoid for t in tracts if t.county == county),
            )
            for county in counties
        ]
    ranges = rule.ranges or similar_ranges([t.base_number for t in tracts], rule.count)
    groups = []
    for low, high in ranges:
        members = frozenset(t.geoid for t in tracts if low <= t.base_number <= high)
        name = f"{low:04d}-{high:04d}" if high != low else f"{low:04d}"  # not "0003-0003"
        groups.append(Group(f"tracts-{low:04d}-{high:04d}", name, members))
    leftover = frozenset(t.geoid for t in tracts) - {g for group in groups for g in group.geoids}
    if leftover:
        groups.append(Group("tracts-other", "Other tracts", leftover))
    return [g for g in groups if g.geoids]


def similar_ranges(numbers: Sequence[int], count: int) -> list[tuple[int, int]]:
    """Up to ``count`` contiguous number ranges holding similar numbers of tracts.

    A base number is never split between two ranges, so the ranges cover the numbers
    in order and each is named by its first and last number.
    """
    distinct = sorted(set(numbers))
    if not distinct:
        return []
    tally = {n: 0 for n in distinct}
    for n in numbers:
        tally[n] += 1
    per_range = len(numbers) / min(count, len(distinct))
    ranges: list[tuple[int, int]] = []
    start, seen = distinct[0], 0
    for index, number in enumerate(distinct):
        seen += tally[number]
        last = index == len(distinct) - 1
        if last or (seen >= per_range * (len(ranges) + 1) and len(ranges) < count - 1):
            ranges.append((start, number))
            if not last:
                start = distinct[index + 1]
    return ranges


def default_settings(
    title: str,
    keys: Sequence[str],
    described: Mapping[str, Attribute] | None = None,
    source: str = "",
    counties: Mapping[str, str] | None = None,
) -> DataSetSettings:
    """Settings for an imported table that came without any: the first four columns are
    the headline, the rest are spread over the information classes in table order.
    Columns the table itself ``described`` (a Census Bureau table's labels, kinds and
    margins) keep that description; the others are called by their names. ``counties``
    names counties by FIPS where the table did."""
    described = described or {}

    def attribute(key: str, info_class: int) -> Attribute:
        known = described.get(key) or Attribute(key=key, label=key)
        return known.model_copy(update={"info_class": info_class})

    rest = list(keys[4:])
    attributes = [attribute(key, 1) for key in keys[:4]]
    attributes += [attribute(key, 2 + (4 * i) // len(rest)) for i, key in enumerate(rest)]
    return DataSetSettings(
        title=title,
        source=source,
        headline=list(keys[:4]),
        attributes=attributes,
        counties=dict(counties or {}),
    )
