"""Wall configs: the TOML format as pydantic models, and how a valid one becomes a Wall.

Reading a wall is tomllib -> ``WallConfig`` (shapes, types, ranges and the rules between
keys) -> ``WallConfig.to_wall`` (the geometry objects of ``wall_client.layout``). Every
problem is reported as one line ``FILE: field.path: message``, so an operator fixing a
config sees which key is wrong and why, never a pydantic dump. docs/wall-config.md
documents every key; tests/test_docs.py reads the keys from these models.

Rules between keys (overlapping displays, unknown display ids in ``[screens]`` ...) are
checked once every value is valid on its own: pydantic runs a model's validators only
then, and a rule over half-read displays would only add noise.
"""

from __future__ import annotations

import json
import re
import tomllib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, get_args
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    field_validator,
    model_validator,
)
from pydantic_core import ErrorDetails, PydanticCustomError

from wall_client.layout import (
    DEFAULT_WALK_UP_DISTANCE_M,
    ROLES,
    ROTATIONS,
    BezelMode,
    Display,
    Rect,
    Rotation,
    Wall,
    mounted_size,
)

DEFAULT_SEAT_DISTANCE_M = 2.0
DEFAULT_NODE = "node1"
STAGE = "stage"  # the [screens] key naming the displays the scene is framed on
RENAMED_KEYS = {
    "scan_distance_m": "renamed: use seat_distance_m (walk-up codes have walk_up_distance_m)"
}
# Largest tolerated difference between horizontal and vertical pixel pitch.
ASPECT_TOLERANCE = 0.03
# Slack for comparing positions computed in floating point (a micrometre).
EPSILON_MM = 1e-3
# Displays per grid row or column: ten times the largest walls built, and a typo such as
# columns = 10000000 is refused instead of building displays for ever.
MAX_GRID_SIDE = 100
MAX_MM = 1e6
MIN_SIZE_MM = 1.0

_WALL_ID = re.compile(r"[a-z0-9-]+")
_DISPLAY_ID = re.compile(r"[A-Za-z0-9_-]+")  # display ids end up in tile URLs
_NODE_NAME = re.compile(r"[A-Za-z0-9_.-]+")  # node names are host-like
_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")  # TOML keys written without quotes

# A rule between keys found these problems: (field path below the model, message).
Problem = tuple[tuple[str | int, ...], str]
_RULES = "wall_rules"  # error type carrying a list of Problems in its context
_MESSAGE = "wall_config"  # error type whose message is already ours


class WallConfigError(ValueError):
    """A wall config is invalid; ``errors`` holds every problem found, one per line."""

    def __init__(self, errors: Sequence[str]) -> None:
        self.errors: list[str] = list(errors)
        super().__init__("\n".join(self.errors))

    def __str__(self) -> str:
        return "\n".join(self.errors)


def _refuse(message: str) -> PydanticCustomError:
    """An error whose message reaches the operator as written (no template braces)."""
    return PydanticCustomError(_MESSAGE, "{message}", {"message": message})


def _rules_broken(problems: list[Problem]) -> PydanticCustomError:
    """One pydantic error carrying several problems, each with its own path."""
    return PydanticCustomError(
        _RULES, "{count} problems", {"count": len(problems), "problems": problems}
    )


# --- value types ---------------------------------------------------------------------


def _only(pattern: re.Pattern[str], describe: str) -> Callable[[str], str]:
    def check(value: str) -> str:
        if not pattern.fullmatch(value):
            raise _refuse(f"{value!r} must use only {describe}")
        return value

    return check


def _time_zone(value: str) -> str:
    """An IANA time zone name the system knows (``Europe/Berlin``, ``UTC``)."""
    try:
        ZoneInfo(value)
    except (ValueError, ZoneInfoNotFoundError):
        raise _refuse(
            f"{value!r} is not a time zone: give an IANA name like 'Europe/Berlin' or 'UTC'"
        ) from None
    return value


def _pair(kind: Literal["integers", "numbers"]) -> Callable[[Any], Any]:
    """The shape of ``[x, y]`` values; each number is then checked on its own."""

    integers = kind == "integers"
    example = "[1920, 1080]" if integers else "[1209.6, 680.4]"

    def check(value: Any) -> Any:
        if (
            not isinstance(value, list | tuple)
            or len(value) != 2
            or (integers and any(isinstance(v, bool) or not isinstance(v, int) for v in value))
        ):
            raise _refuse(f"must be a pair of {kind}, like {example}")
        return tuple(value)

    return check


def _rotation(value: Any) -> Any:
    if isinstance(value, bool) or value not in ROTATIONS:
        raise _refuse(f"must be one of {', '.join(map(str, ROTATIONS))} (got {value!r})")
    return int(value)


def _id_list(value: Any) -> Any:
    listed = [value] if isinstance(value, str) else value
    if not isinstance(listed, list) or not all(isinstance(i, str) for i in listed):
        raise _refuse("must be a display id or a list of display ids")
    return tuple(listed)


def _no_repeats(ids: tuple[str, ...]) -> tuple[str, ...]:
    if len(set(ids)) != len(ids):
        raise _refuse("lists a display more than once")
    return ids


Text = Annotated[str, Field(strict=True, min_length=1)]
WallId = Annotated[Text, AfterValidator(_only(_WALL_ID, "lowercase letters, digits and '-'"))]
DisplayId = Annotated[Text, AfterValidator(_only(_DISPLAY_ID, "letters, digits, '_' and '-'"))]
NodeName = Annotated[Text, AfterValidator(_only(_NODE_NAME, "letters, digits, '_', '.' and '-'"))]
TimeZoneName = Annotated[Text, Field(max_length=64), AfterValidator(_time_zone)]
Number = Annotated[float, Field(strict=True, allow_inf_nan=False)]
Positive = Annotated[Number, Field(gt=0)]
# Millimetres on the wall stay within a kilometre and sizes above a millimetre, so the
# geometry built from them never overflows or divides by (nearly) zero.
Coordinate = Annotated[Number, Field(ge=-MAX_MM, le=MAX_MM)]
Length = Annotated[Coordinate, Field(ge=0)]
Size = Annotated[Coordinate, Field(ge=MIN_SIZE_MM)]
Count = Annotated[int, Field(strict=True, gt=0)]
Index = Annotated[int, Field(strict=True, ge=0)]
Pixels = Annotated[tuple[Count, Count], BeforeValidator(_pair("integers"))]
DesktopPoint = Annotated[
    tuple[Annotated[int, Field(strict=True)], Annotated[int, Field(strict=True)]],
    BeforeValidator(_pair("integers")),
]
SizeMm = Annotated[tuple[Size, Size], BeforeValidator(_pair("numbers"))]
RotationValue = Annotated[Rotation, BeforeValidator(_rotation)]
DisplayIds = Annotated[tuple[str, ...], BeforeValidator(_id_list), AfterValidator(_no_repeats)]

# Keys taking one number or a structured form: the form's tag appears in pydantic's
# error locations and is left out of the field paths people read.
_ONE_NUMBER, _PER_SIDE, _PER_AXIS = "(one number)", "(per side)", "(per axis)"
_FORM_TAGS = {_ONE_NUMBER, _PER_SIDE, _PER_AXIS}


def _number_unless(form: type, tag: str) -> Callable[[Any], str]:
    """Values of type ``form`` take the structured form, anything else is one number."""
    return lambda value: tag if isinstance(value, form) else _ONE_NUMBER


# --- tables --------------------------------------------------------------------------


class _Table(BaseModel):
    """A TOML table: unknown keys are errors, so typos do not pass silently."""

    model_config = ConfigDict(extra="forbid")
    key_kind: ClassVar[str] = "key"  # what an unknown key is called in messages


class WallSize(_Table):
    width_mm: Size | None = None
    height_mm: Size | None = None


class BezelSides(_Table):
    left: Length
    right: Length
    top: Length
    bottom: Length


Bezel = Annotated[
    Annotated[Length, Tag(_ONE_NUMBER)] | Annotated[BezelSides, Tag(_PER_SIDE)],
    Discriminator(_number_unless(dict, _PER_SIDE)),
]
Gap = Annotated[
    Annotated[Length, Tag(_ONE_NUMBER)]
    | Annotated[tuple[Length, Length], BeforeValidator(_pair("numbers")), Tag(_PER_AXIS)],
    Discriminator(_number_unless(list, _PER_AXIS)),
]


class ScreensConfig(_Table):
    """Displays per role; ``None`` means the default (see docs/wall-config.md)."""

    key_kind = "role"

    public: DisplayIds = ()
    menu: DisplayIds = ()
    registration: DisplayIds | None = None  # None: the lower-left display
    stage: DisplayIds | None = None  # None: the wall computes the largest free block

    @field_validator(STAGE)
    @classmethod
    def _stage_names_a_display(cls, ids: tuple[str, ...] | None) -> tuple[str, ...] | None:
        if ids == ():
            raise _refuse("give at least one display (leave it out for the default)")
        return ids

    def listed(self) -> Iterator[tuple[str, tuple[str, ...]]]:
        """Every role given, with its display ids."""
        for role in type(self).model_fields:
            ids = getattr(self, role)
            if ids is not None:
                yield role, ids


def _square_pixels(width: float, height: float, mounted: tuple[int, int]) -> str | None:
    """Pixels must be (nearly) square, or the config's size or resolution is wrong."""
    pitch_ratio = (width / mounted[0]) / (height / mounted[1])
    if abs(pitch_ratio - 1) <= ASPECT_TOLERANCE:
        return None
    return (
        f"active area {width:g} x {height:g} mm (aspect {width / height:.3f})"
        f" does not match {mounted[0]} x {mounted[1]} px as mounted"
        f" (aspect {mounted[0] / mounted[1]:.3f}): pixels would not be square"
        f" (off by {abs(pitch_ratio - 1):.1%}, more than {ASPECT_TOLERANCE:.0%})"
    )


GridSide = Annotated[Count, Field(le=MAX_GRID_SIDE)]


class GridConfig(_Table):
    """Identical displays in rows and columns, named ``r{row}c{column}``."""

    columns: GridSide
    rows: GridSide
    resolution: Pixels
    active_mm: SizeMm
    bezel_mm: Bezel = Field(json_schema_extra={"hint": "0 for bezel-less panels"})
    gap_mm: Gap = 0.0
    displays_per_node: Count = 1
    node_prefix: NodeName = "node"
    rotation: RotationValue = 0

    @model_validator(mode="after")
    def _square(self) -> GridConfig:
        width, height = self.active_mm
        problem = _square_pixels(width, height, mounted_size(self.resolution, self.rotation))
        if problem:
            raise _rules_broken([(("active_mm",), problem)])
        return self

    @property
    def sides(self) -> tuple[float, float, float, float]:
        """Bezel widths (left, right, top, bottom)."""
        b = self.bezel_mm
        if isinstance(b, BezelSides):
            return (b.left, b.right, b.top, b.bottom)
        return (b, b, b, b)

    @property
    def gaps(self) -> tuple[float, float]:
        """Extra space between neighbouring panels along x and y."""
        return self.gap_mm if isinstance(self.gap_mm, tuple) else (self.gap_mm, self.gap_mm)

    @property
    def pitch(self) -> tuple[float, float]:
        """Distance between neighbouring displays' active areas along x and y."""
        left, right, top, bottom = self.sides
        gap_x, gap_y = self.gaps
        return (left + self.active_mm[0] + right + gap_x, top + self.active_mm[1] + bottom + gap_y)

    def size(self) -> tuple[float, float]:
        """The wall's natural size: outer bezels included, the last gap not."""
        gap_x, gap_y = self.gaps
        pitch_x, pitch_y = self.pitch
        return (self.columns * pitch_x - gap_x, self.rows * pitch_y - gap_y)

    def displays(self) -> list[Display]:
        left, _, top, _ = self.sides
        pitch_x, pitch_y = self.pitch
        width, height = self.active_mm
        displays: list[Display] = []
        for i in range(self.columns * self.rows):
            row, col = divmod(i, self.columns)
            index = i % self.displays_per_node
            displays.append(
                Display(
                    id=f"r{row + 1}c{col + 1}",
                    rect=Rect(col * pitch_x + left, row * pitch_y + top, width, height),
                    resolution=self.resolution,
                    rotation=self.rotation,
                    node=f"{self.node_prefix}{i // self.displays_per_node + 1}",
                    index=index,
                    # The OS does not rotate: windows sit side by side at native width.
                    desktop_origin=(index * self.resolution[0], 0),
                )
            )
        return displays


class DisplayConfig(_Table):
    """One ``[[display]]`` entry; node index and desktop origin default by position."""

    id: DisplayId
    x_mm: Coordinate
    y_mm: Coordinate
    width_mm: Size
    height_mm: Size
    resolution: Pixels
    rotation: RotationValue = 0
    node: NodeName = DEFAULT_NODE
    index: Index | None = None
    desktop_origin: DesktopPoint | None = None

    @model_validator(mode="after")
    def _square(self) -> DisplayConfig:
        mounted = mounted_size(self.resolution, self.rotation)
        problem = _square_pixels(self.width_mm, self.height_mm, mounted)
        if problem:
            raise _rules_broken([(("resolution",), problem)])
        return self

    @property
    def rect(self) -> Rect:
        return Rect(self.x_mm, self.y_mm, self.width_mm, self.height_mm)


def _display_array(value: Any) -> Any:
    if not isinstance(value, list):
        raise _refuse("must be an array of tables, written as [[display]] sections")
    if not value:
        raise _refuse("at least one [[display]] is required")
    return value


# --- explicit displays on their nodes ------------------------------------------------


def _node_indices(entries: Sequence[DisplayConfig]) -> list[int]:
    """Each entry's index on its node: as given, else its order of appearance there."""
    appeared: dict[str, int] = {}
    indices: list[int] = []
    for entry in entries:
        position = appeared.get(entry.node, 0)
        appeared[entry.node] = position + 1
        indices.append(position if entry.index is None else entry.index)
    return indices


def _desktop_origin(
    entries: Sequence[DisplayConfig], indices: Sequence[int], i: int
) -> tuple[int, int]:
    """As given, else side by side at native width by index (the OS does not rotate)."""
    entry = entries[i]
    if entry.desktop_origin is not None:
        return entry.desktop_origin
    left = sum(
        other.resolution[0]
        for other, other_index in zip(entries, indices, strict=True)
        if other.node == entry.node and other_index < indices[i]
    )
    return (left, 0)


def _explicit_displays(entries: Sequence[DisplayConfig]) -> list[Display]:
    indices = _node_indices(entries)
    return [
        Display(
            id=entry.id,
            rect=entry.rect,
            resolution=entry.resolution,
            rotation=entry.rotation,
            node=entry.node,
            index=indices[i],
            desktop_origin=_desktop_origin(entries, indices, i),
        )
        for i, entry in enumerate(entries)
    ]


def _duplicate_ids(entries: Sequence[DisplayConfig]) -> Iterator[Problem]:
    first: dict[str, int] = {}
    for i, entry in enumerate(entries):
        if entry.id in first:
            message = f"duplicate display id {entry.id!r} (also display[{first[entry.id]}])"
            yield ("display", i, "id"), message
        else:
            first[entry.id] = i


def _index_clashes(entries: Sequence[DisplayConfig]) -> Iterator[Problem]:
    taken: dict[tuple[str, int], int] = {}
    for i, (entry, index) in enumerate(zip(entries, _node_indices(entries), strict=True)):
        key = (entry.node, index)
        if key in taken:
            message = (
                f"index {index} on node {entry.node!r} is already used by display[{taken[key]}]"
            )
            yield ("display", i, "index"), message
        else:
            taken[key] = i


# --- displays on the wall ------------------------------------------------------------


# Each display with the path naming it in messages ("grid" for every grid display).
Placed = list[tuple[tuple[str | int, ...], Display]]


def _outside_wall(placed: Placed, width: float, height: float, explicit: bool) -> Iterator[Problem]:
    """Every display must lie on the wall (a grid leaves it only when [wall] is too small)."""
    margin = Rect(-EPSILON_MM, -EPSILON_MM, width + 2 * EPSILON_MM, height + 2 * EPSILON_MM)
    size = "wall.width_mm x wall.height_mm" if explicit else "the wall's extent"
    for path, display in placed:
        r = display.rect
        if margin.contains(r):
            continue
        if path == ("grid",):
            yield from _grid_outside_wall(display, margin, width, height)
            continue
        where = f"{r.x:g}..{r.right:g} x {r.y:g}..{r.bottom:g} mm"
        message = f"is not within {size} {width:g} x {height:g} mm"
        yield path, f"display outside the wall: {where} {message}"


def _grid_outside_wall(
    display: Display, margin: Rect, width: float, height: float
) -> Iterator[Problem]:
    """A grid display beyond the wall: [wall] gives too small a size."""
    r = display.rect
    if r.right > margin.right:
        where = f"{display.id} reaches x = {r.right:g} mm, beyond {width:g} mm"
        yield ("wall", "width_mm"), f"display outside the wall: {where}"
    if r.bottom > margin.bottom:
        where = f"{display.id} reaches y = {r.bottom:g} mm, beyond {height:g} mm"
        yield ("wall", "height_mm"), f"display outside the wall: {where}"


def _overlaps(placed: Placed) -> Iterator[Problem]:
    """Displays must not overlap; touching edges (within a micrometre) are fine."""
    for i, (a_path, a) in enumerate(placed):
        for b_path, b in placed[:i]:
            overlap_w, overlap_h = a.rect.overlap(b.rect)
            if overlap_w > EPSILON_MM and overlap_h > EPSILON_MM:
                other = f"display {b.id!r} ({_path(b_path)})"
                size = f"{overlap_w:g} x {overlap_h:g} mm"
                yield a_path, f"display {a.id!r} overlaps {other} by {size}"


def _unknown_screens(screens: ScreensConfig, known: set[str]) -> Iterator[Problem]:
    for role, ids in screens.listed():
        for display_id in ids:
            if display_id not in known:
                yield ("screens", role), f"unknown display {display_id!r}"


class WallConfig(_Table):
    """One wall config file: the top level of the TOML document."""

    id: WallId
    name: Text | None = None  # None: the id
    bezel_mode: BezelMode = "overlay"
    seat_distance_m: Positive = DEFAULT_SEAT_DISTANCE_M
    walk_up_distance_m: Positive = DEFAULT_WALK_UP_DISTANCE_M
    time_zone: TimeZoneName = "UTC"
    screens: ScreensConfig = Field(default_factory=ScreensConfig)
    wall: WallSize = Field(default_factory=WallSize)
    grid: GridConfig | None = None
    display: Annotated[list[DisplayConfig], BeforeValidator(_display_array)] | None = None

    @model_validator(mode="after")
    def _rules_between_keys(self) -> WallConfig:
        if self.grid is not None and self.display is not None:
            raise _rules_broken(
                [(("grid",), "give either a [grid] table or [[display]] entries, not both")]
            )
        if self.grid is None and self.display is None:
            raise _rules_broken(
                [(("grid",), "missing: give either a [grid] table or [[display]] entries")]
            )
        width, height = self.extent
        problems = [
            *_duplicate_ids(self.display or ()),
            *_index_clashes(self.display or ()),
            *_outside_wall(self.placed, width, height, bool(self.wall.model_fields_set)),
            *_overlaps(self.placed),
            *_unknown_screens(self.screens, {display.id for _, display in self.placed}),
        ]
        if problems:
            raise _rules_broken(problems)
        return self

    @cached_property
    def placed(self) -> Placed:
        """The displays in config order, each with the path that names it in messages."""
        if self.grid is not None:
            return [(("grid",), display) for display in self.grid.displays()]
        entries = self.display or []
        return [(("display", i), d) for i, d in enumerate(_explicit_displays(entries))]

    @property
    def extent(self) -> tuple[float, float]:
        """The wall's size: as given, else the displays' natural extent."""
        if self.grid is not None:
            natural = self.grid.size()
        else:
            rects = [display.rect for _, display in self.placed]
            natural = (max(r.right for r in rects), max(r.bottom for r in rects))
        return (self.wall.width_mm or natural[0], self.wall.height_mm or natural[1])

    def roles(self) -> dict[str, tuple[str, ...]]:
        """Displays per panel role, registration defaulting to the lower-left display
        (people register where they walk up, usually a corner at eye level)."""
        registration = self.screens.registration
        if registration is None:
            displays = [display for _, display in self.placed]
            lower_left = min(displays, key=lambda d: (-d.rect.bottom, d.rect.x))
            registration = (lower_left.id,)
        screens = {
            "public": self.screens.public,
            "menu": self.screens.menu,
            "registration": registration,
        }
        return {role: screens[role] for role in ROLES}

    def to_wall(self, source: Path | None = None) -> Wall:
        width, height = self.extent
        return Wall(
            id=self.id,
            name=self.name or self.id,
            width=width,
            height=height,
            displays=tuple(display for _, display in self.placed),
            bezel_mode=self.bezel_mode,
            screens=self.roles(),
            seat_distance_m=self.seat_distance_m,
            walk_up_distance_m=self.walk_up_distance_m,
            time_zone=self.time_zone,
            stage_ids=self.screens.stage or (),
            source=source,
        )


# --- error messages ------------------------------------------------------------------


_MESSAGES = {
    "float_type": "must be a number",
    "int_type": "must be an integer",
    "finite_number": "must be a finite number",
    "string_type": "must be a non-empty string",
    "string_too_short": "must be a non-empty string",
    "model_type": "must be a table",
    "model_attributes_type": "must be a table",
}


def _path(loc: Iterable[str | int]) -> str:
    """``("display", 2, "rotation")`` -> ``display[2].rotation``; odd keys quoted as in TOML."""
    text = ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
        elif part not in _FORM_TAGS:
            key = part if _BARE_KEY.fullmatch(part) else json.dumps(part)
            text += f".{key}" if text else key
    return text


def _table_in(annotation: Any) -> type[_Table] | None:
    """The table model a field holds, looking through ``list``, ``| None`` and unions."""
    if isinstance(annotation, type) and issubclass(annotation, _Table):
        return annotation
    for arg in get_args(annotation):
        found = _table_in(arg)
        if found is not None:
            return found
    return None


def _table_at(loc: Sequence[str | int]) -> type[_Table] | None:
    """The table model holding the value at ``loc`` (None past a scalar)."""
    table: type[_Table] | None = WallConfig
    for part in loc:
        if isinstance(part, int) or part in _FORM_TAGS:
            continue
        if table is None or part not in table.model_fields:
            return None
        table = _table_in(table.model_fields[part].annotation)
    return table


def _unknown_key(loc: Sequence[str | int]) -> str:
    key = loc[-1]
    if len(loc) == 1 and isinstance(key, str) and key in RENAMED_KEYS:
        return RENAMED_KEYS[key]
    table = _table_at(loc[:-1])
    if table is None:
        return "unknown key"
    return f"unknown {table.key_kind} (expected one of: {', '.join(table.model_fields)})"


def _missing(loc: Sequence[str | int]) -> str:
    table = _table_at(loc[:-1])
    field = table.model_fields.get(str(loc[-1])) if table is not None else None
    extra = field.json_schema_extra if field is not None else None
    hint = extra.get("hint") if isinstance(extra, dict) else None
    return f"required ({hint})" if hint else "required"


def _message(error: ErrorDetails) -> str:
    """One pydantic error in the words of docs/wall-config.md."""
    kind, loc, ctx = error["type"], error["loc"], error.get("ctx", {})
    if kind == "extra_forbidden":
        return _unknown_key(loc)
    if kind == "missing":
        return _missing(loc)
    if kind == "literal_error":
        expected = str(ctx["expected"]).replace(" or ", ", ")
        return f"must be one of {expected} (got {error['input']!r})"
    if kind == "greater_than" and ctx.get("gt") == 0:
        return "must be positive"
    unit = " mm" if any(str(part).endswith("_mm") for part in loc) else ""
    if kind == "greater_than_equal":
        if ctx["ge"] == 0:
            return "must not be negative"
        return f"must be at least {ctx['ge']:.15g}{unit}"
    if kind == "less_than_equal":
        return f"must be at most {ctx['le']:.15g}{unit}"
    return _MESSAGES.get(kind, error["msg"])


def _problem_lines(label: str, error: ValidationError) -> list[str]:
    """``FILE: field.path: message`` for every problem pydantic found."""
    lines: list[str] = []
    for item in error.errors(include_url=False):
        if item["type"] == _RULES:
            problems: list[Problem] = item["ctx"]["problems"]
            lines.extend(f"{label}: {_path((*item['loc'], *p))}: {m}" for p, m in problems)
        else:
            lines.append(f"{label}: {_path(item['loc'])}: {_message(item)}")
    return lines


# --- loading -------------------------------------------------------------------------


def config_keys(table: type[_Table] = WallConfig, prefix: str = "") -> list[str]:
    """Every key a wall config accepts, dotted (``grid.bezel_mm.left``); the docs list each."""
    keys: list[str] = []
    for name, field in table.model_fields.items():
        keys.append(prefix + name)
        inner = _table_in(field.annotation)
        if inner is not None:
            keys.extend(config_keys(inner, f"{prefix}{name}."))
    return keys


def parse_wall(data: Mapping[str, Any], source: str | Path | None = None) -> Wall:
    """Validate a parsed TOML document into a Wall; WallConfigError lists every problem."""
    label = str(source) if source is not None else "<string>"
    try:
        config = WallConfig.model_validate(data)
    except ValidationError as error:
        raise WallConfigError(_problem_lines(label, error)) from None
    return config.to_wall(Path(source) if source is not None else None)


def load_wall(path: str | Path) -> Wall:
    """Read and validate one TOML wall config; unreadable files are config errors too."""
    path = Path(path)
    try:
        with path.open("rb") as file:
            data = tomllib.load(file)
    except FileNotFoundError:
        raise WallConfigError([f"{path}: no such file"]) from None
    except IsADirectoryError:
        raise WallConfigError([f"{path}: is a directory, expected a .toml file"]) from None
    except OSError as error:
        raise WallConfigError([f"{path}: cannot read: {error.strerror or error}"]) from None
    except UnicodeDecodeError as error:
        raise WallConfigError([f"{path}: not UTF-8 text: {error}"]) from None
    except tomllib.TOMLDecodeError as error:
        raise WallConfigError([f"{path}: TOML syntax error: {error}"]) from None
    return parse_wall(data, path)


def load_walls(paths: Iterable[str | Path]) -> dict[str, Wall]:
    """Load every wall from files and folders of ``*.toml`` (sorted by name), keyed by id.

    Problems in all files are reported together, and a wall id used twice is an
    error naming both files.
    """
    files: list[Path] = []
    for entry in map(Path, paths):
        if entry.is_dir():
            files.extend(sorted(entry.glob("*.toml"), key=lambda p: p.name))
        else:
            files.append(entry)
    walls: dict[str, Wall] = {}
    errors: list[str] = []
    for file in files:
        try:
            wall = load_wall(file)
        except WallConfigError as error:
            errors.extend(error.errors)
            continue
        if wall.id in walls:
            first = walls[wall.id].source
            errors.append(f"{file}: id: duplicate wall id {wall.id!r} (also in {first})")
            continue
        walls[wall.id] = wall
    if errors:
        raise WallConfigError(errors)
    return walls
