"""Tables as the Census Bureau's data.census.gov hands them out, read for the census
import: a ``...-Data.csv`` whose first row holds column codes (``GEO_ID``, ``NAME``,
``B19013_001E``, ``B19013_001M``, ...) and whose second row repeats their labels, and
beside it (in the same downloaded zip) a ``...-Column-Metadata.csv`` mapping each code
to its label (``Estimate!!Median household income in the past 12 months (in 2022
inflation-adjusted dollars)``, ``Margin of Error!!...``). Downloads from before 2023
(``..._data_with_overlays_<time>.csv`` with ``..._metadata_<time>.csv``, labels under
an ``id`` row) read the same way.

Out comes what the importer needs: estimates and their margins of error as numbers,
keyed as tract outlines are (``GEO_ID`` ``1400000US06067000100`` -> ``06067000100``),
and readable labels from the metadata. The Bureau's symbols in place of numbers mean
"no value" or say how to read one ("250,000+"); any other text stops the import with
its cell named. Nothing here knows the database or the rest of the import.
"""

from __future__ import annotations

import csv
import io
import re
import zipfile
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from webapp.apps.census_map.dataset import OPEN_ABOVE, OPEN_BELOW, Attribute, Kind, Value

KEY = "GEO_ID"
LABEL_ROW = frozenset({"Geography", "id"})  # what the label row has under GEO_ID
DATA_SUFFIX = "-Data.csv"
METADATA_SUFFIX = "-Column-Metadata.csv"
OLD_DATA = re.compile(r"_data_with_overlays_")  # downloads from before 2023
OLD_METADATA = "_metadata_"
# The American Community Survey's "jam values": codes standing in for an estimate or a
# margin that could not be made (too few samples, not applicable, ...), never numbers.
JAM_VALUES = frozenset({-666666666, -999999999, -888888888, -222222222, -333333333, -555555555})
# The symbols the Bureau prints instead of numbers ("Explanation of Symbols" in every
# table's notes). In an estimate: "-" too few sample observations, "N" not displayed
# for too few cases, "(X)" not applicable; a median ending in "+" or "-" ("250,000+")
# lies in the open-ended top or bottom interval. In a margin: "**" too few
# observations to compute one, "***" the median is open-ended, "*****" the estimate is
# controlled (no sampling error to speak of). "null" marks an empty annotation.
NO_ESTIMATE = frozenset({"", "-", "N", "(X)", "null"})
NO_MARGIN = frozenset({"", "-", "N", "(X)", "null", "**", "*****"})
OPEN_MARGIN = "***"
SYMBOLS = "-, N, (X), null, **, ***, *****, a bound such as 250,000+"
NUMBER = re.compile(r"[+-]?(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?")
BOUND = re.compile(r"(?P<number>(?:\d{1,3}(?:,\d{3})+|\d+)(?:\.\d+)?)(?P<side>[+-])")
STEM = re.compile(r"[A-Z0-9]+\.[A-Z0-9]+")
PRODUCT = re.compile(r"ACS(?:DT|ST|DP|CP|SPP|SE)(?P<years>[15])Y(?P<year>\d{4})")
LABEL_LENGTH = 120  # Attribute.label, DataSetSettings.title
SOURCE_LENGTH = 2_000  # DataSetSettings.source


class TableError(ValueError):
    """A Census Bureau table that cannot be read, with a one-line reason."""


@dataclass(frozen=True)
class CensusTable:
    """One downloaded table: its estimate columns, each estimate's margin column, the
    metadata's labels, and the values by tract key."""

    name: str  # the data file as people call it: "ACSDT5Y2022.B19013-Data.csv"
    product: str  # "ACSDT5Y2022" ("" when the file name does not say)
    table: str  # "B19013"
    estimates: list[str]
    margins: dict[str, str]  # estimate column -> its margin of error's column
    labels: dict[str, str]  # estimate column -> the metadata's label
    records: dict[str, dict[str, Value]]  # by key: estimates and margins
    left_out: list[str]  # text columns (NAME)
    counties: dict[str, str]  # county FIPS -> its name, as NAME gives it


def is_census_table(path: Path) -> bool:
    """A downloaded zip, or a CSV that starts with GEO_ID and a label row (or has the
    download's metadata file beside it)."""
    if path.suffix.lower() == ".zip":
        return True
    try:
        with path.open(encoding="utf-8-sig", newline="") as file:
            rows = [row for _, row in zip(range(2), csv.reader(file), strict=False)]
    except (OSError, UnicodeDecodeError, csv.Error):
        return False  # the importer's own reading says what is wrong
    if not rows or not rows[0] or rows[0][0].strip() != KEY:
        return False
    labelled = len(rows) > 1 and bool(rows[1]) and rows[1][0].strip() in LABEL_ROW
    return labelled or _metadata_path(path).is_file()


def read(path: Path, *, full_ids: bool) -> list[CensusTable]:
    """The tables of ``path`` (a ``-Data.csv`` with its metadata beside it, or the zip
    data.census.gov gave, holding one or more tables). ``full_ids``: key rows by the
    whole GEO_ID (``1400000US06067000100``), else by the GEOID after ``US``."""
    return [
        _table(name, data, metadata_name, metadata, full_ids)
        for name, data, metadata_name, metadata in _files(path)
    ]


# -- files -----------------------------------------------------------------------------


def _metadata_name(data_name: str) -> str | None:
    """The metadata file's name for a data file's name, as the download names them."""
    if data_name.endswith(DATA_SUFFIX):
        return data_name.removesuffix(DATA_SUFFIX) + METADATA_SUFFIX
    if OLD_DATA.search(data_name):
        return OLD_DATA.sub(OLD_METADATA, data_name, count=1)
    return None


def _metadata_path(path: Path) -> Path:
    """Where a data file's metadata lies: beside it, named as the download names it."""
    return path.with_name(_metadata_name(path.name) or f"{path.stem}{METADATA_SUFFIX}")


def _files(path: Path) -> list[tuple[str, str, str, str]]:
    """(data name, data text, metadata name, metadata text) per table."""
    if path.suffix.lower() == ".zip":
        return _zipped(path)
    metadata = _metadata_path(path)
    if not metadata.is_file():
        raise TableError(
            f"{path.name} is a data.census.gov table, but its column metadata is missing: "
            f"put {metadata.name} (from the same download) beside it, or give the downloaded .zip"
        )
    return [(path.name, _read(path), metadata.name, _read(metadata))]


def _read(path: Path) -> str:
    try:
        return _text(path.name, path.read_bytes())
    except OSError as error:
        raise TableError(f"cannot read {path}: {error.strerror}") from error


def _zipped(path: Path) -> list[tuple[str, str, str, str]]:
    try:
        with zipfile.ZipFile(path) as archive:
            members = {
                PurePosixPath(m).name: m
                for m in archive.namelist()
                if not m.startswith("__MACOSX/") and not m.endswith("/")
            }
            data = sorted(n for n in members if _metadata_name(n) is not None)
            if not data:
                raise TableError(
                    f"{path.name}: no data.census.gov table in it (no file named ...{DATA_SUFFIX})"
                )
            files = []
            for name in data:
                expected = _metadata_name(name) or ""
                if expected not in members:
                    raise TableError(
                        f"{path.name}: {name} is there but its column metadata {expected} is not"
                    )
                files.append(
                    (
                        f"{name} (in {path.name})",
                        _text(name, archive.read(members[name])),
                        expected,
                        _text(expected, archive.read(members[expected])),
                    )
                )
            return files
    except (zipfile.BadZipFile, OSError) as error:
        raise TableError(f"{path.name}: not a readable zip file: {error}") from error


def _text(name: str, data: bytes) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise TableError(f"{name}: not a UTF-8 CSV file: {error}") from error


def _rows(name: str, text: str) -> list[list[str]]:
    try:
        return [row for row in csv.reader(io.StringIO(text, newline="")) if any(row)]
    except csv.Error as error:
        raise TableError(f"{name}: not a readable CSV file: {error}") from error


# -- one table ------------------------------------------------------------------------


def _read_metadata(name: str, text: str) -> dict[str, str]:
    """Column code -> label. Today's files start with a "Column Name","Label" header;
    older ones go straight to "GEO_ID","id"."""
    rows = _rows(name, text)
    if rows and [cell.strip() for cell in rows[0][:2]] == ["Column Name", "Label"]:
        rows = rows[1:]
    labels: dict[str, str] = {}
    for line, row in enumerate(rows, start=1):
        if len(row) < 2 or not row[0].strip():
            raise TableError(f"{name}: line {line} is not a column code and its label")
        labels[row[0].strip()] = row[1]
    if not labels:
        raise TableError(f"{name}: no columns described")
    return labels


def _table(name: str, data: str, metadata_name: str, metadata: str, full_ids: bool) -> CensusTable:
    labels = _read_metadata(metadata_name, metadata)
    rows = _rows(name, data)
    if not rows:
        raise TableError(f"{name}: empty")
    header = [cell.strip() for cell in rows[0]]
    while header and not header[-1]:  # every line of a download ends in a comma
        header.pop()
    if KEY not in header:
        raise TableError(f"{name}: no {KEY} column, so not a data.census.gov table")
    twice = sorted(c for c, n in Counter(header).items() if n > 1)
    if twice:
        raise TableError(f"{name}: columns named twice: {', '.join(twice)}")
    _require_matching(name, metadata_name, header, labels)
    body = rows[1:]
    key = header.index(KEY)
    if body and len(body[0]) > key and body[0][key].strip() in LABEL_ROW:
        _require_same_labels(name, metadata_name, header, body.pop(0), labels)

    roles = {code: _role(code, labels[code]) for code in header}
    estimates = [c for c in header if roles[c] == "estimate"]
    margins = {
        _estimate_of(c): c for c in header if roles[c] == "margin" and _estimate_of(c) in estimates
    }
    notes = {c[:-1]: c for c in header if roles[c] == "annotation" and c[:-1] in header}
    records: dict[str, dict[str, Value]] = {}
    counties: dict[str, str] = {}
    for line, row in enumerate(body, start=3):
        if len(row) < len(header):
            raise TableError(f"{name}: row {line} has {len(row)} cells for {len(header)} columns")
        cells = dict(zip(header, (cell.strip() for cell in row), strict=False))
        geo_id = cells[KEY]
        if not geo_id:
            raise TableError(f"{name}: row {line} has no {KEY}")
        tract = geo_id if full_ids or "US" not in geo_id else geo_id.split("US", 1)[1]
        if tract in records:
            raise TableError(f"{name}: {KEY} {geo_id} appears twice")
        records[tract] = _values(name, geo_id, cells, notes, estimates, margins)
        counties.update(_county(geo_id, cells.get("NAME", "")))
    return CensusTable(
        name=name,
        product=_stem(name).partition(".")[0],
        table=_stem(name).partition(".")[2],
        estimates=estimates,
        margins=margins,
        labels={c: labels[c] for c in estimates},
        records=records,
        left_out=[c for c in header if roles[c] == "text"],
        counties=counties,
    )


def _county(geo_id: str, place: str) -> dict[str, str]:
    """A tract's (or block group's) county FIPS and name from its GEO_ID and NAME
    ("Census Tract 1; Sacramento County; California", commas before 2023)."""
    digits = geo_id.split("US", 1)[-1]
    parts = [p.strip() for p in place.split(";" if ";" in place else ",")]
    if len(digits) < 11 or not digits.isdigit() or len(parts) < 3 or not parts[-2]:
        return {}
    return {digits[:5]: parts[-2]}


def _stem(name: str) -> str:
    """ "ACSDT5Y2022.B19013" of "ACSDT5Y2022.B19013-Data.csv" (and of the older names);
    "" for a file renamed since."""
    base = name.split(" (in ")[0]
    stem = OLD_DATA.split(base.removesuffix(DATA_SUFFIX))[0]
    return stem if STEM.fullmatch(stem) else ""


def _require_matching(
    name: str, metadata_name: str, header: list[str], labels: dict[str, str]
) -> None:
    """The metadata must describe exactly the data's columns (annotation columns, which
    some downloads leave out, aside): else it belongs to another download."""
    undescribed = [c for c in header if c not in labels]
    if undescribed:
        raise TableError(
            f"{metadata_name} does not describe {_few(undescribed)} of {name}: "
            f"the metadata must come from the same download as the data"
        )
    absent = [
        c for c, label in labels.items() if c not in header and _role(c, label) != "annotation"
    ]
    if absent:
        raise TableError(
            f"{metadata_name} describes {_few(absent)}, which {name} lacks: "
            f"the metadata must come from the same download as the data"
        )


def _require_same_labels(
    name: str, metadata_name: str, header: list[str], row: list[str], labels: dict[str, str]
) -> None:
    for code, label in zip(header, row, strict=False):
        if _plain(label) != _plain(labels[code]):
            raise TableError(
                f"{name} and {metadata_name} label {code} differently ({label.strip()!r}, "
                f"{labels[code].strip()!r}): the metadata must come from the same download"
            )


def _few(items: Sequence[str], limit: int = 5) -> str:
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more


def _plain(label: str) -> str:
    """A label as compared and shown: without the stray quotes some labels carry (a
    label holding "very well" is written unescaped) and with single spaces."""
    return " ".join(label.replace('"', "").split())


def _role(code: str, label: str) -> str:
    """key | text | estimate | margin | annotation, from the metadata's label."""
    first = _plain(label).split("!!")[0].strip().lower()
    if code == KEY:
        return "key"
    if first.startswith("annotation of"):
        return "annotation"
    if "margin of error" in first:
        return "margin"
    if code == "NAME" or first == "geographic area name":
        return "text"
    return "estimate"


def _estimate_of(margin: str) -> str:
    """B19013_001M -> B19013_001E; DP05_0001PM -> DP05_0001PE."""
    return margin[:-1] + "E"


# -- cells ----------------------------------------------------------------------------


def _values(
    name: str,
    geo_id: str,
    cells: dict[str, str],
    notes: dict[str, str],
    estimates: list[str],
    margins: dict[str, str],
) -> dict[str, Value]:
    """One row's estimates and margins. An annotation, where there is one, stands in
    for its cell (the Bureau's rule for its EA and MA columns)."""

    def cell(code: str) -> str:
        note = cells.get(notes[code], "") if code in notes else ""
        return note if note not in ("", "null") else cells.get(code, "")

    values: dict[str, Value] = {}
    for code in estimates:
        value, side = _estimate(name, geo_id, code, cell(code))
        values[code] = value
        if code in margins:
            margin = margins[code]
            values[margin] = _margin(name, geo_id, margin, cell(margin), side)
    return values


def _estimate(name: str, geo_id: str, code: str, text: str) -> tuple[Value, float | None]:
    """The estimate, and OPEN_ABOVE/OPEN_BELOW when it is a bound ("250,000+")."""
    if text in NO_ESTIMATE:
        return None, None
    if bound := BOUND.fullmatch(text):
        side = OPEN_ABOVE if bound.group("side") == "+" else OPEN_BELOW
        return _number(bound.group("number")), side
    if NUMBER.fullmatch(text):
        number = _number(text)
        return (None if number in JAM_VALUES else number), None
    raise _not_a_number(name, geo_id, code, text)


def _margin(name: str, geo_id: str, code: str, text: str, side: float | None) -> Value:
    """The margin, None when there is none; beside a bound, which way the value lies
    (the bound has no margin to speak of)."""
    if text in NO_MARGIN or text == OPEN_MARGIN:
        margin = None
    elif NUMBER.fullmatch(text):
        number = _number(text)
        margin = None if number in JAM_VALUES or number < 0 else number
    else:
        raise _not_a_number(name, geo_id, code, text)
    return side if side is not None else margin


def _number(text: str) -> float:
    plain = text.replace(",", "")
    return int(plain) if plain.lstrip("+-").isdigit() else float(plain)


def _not_a_number(name: str, geo_id: str, code: str, text: str) -> TableError:
    return TableError(
        f"{name}: {code} of {geo_id} reads {text!r}, neither a number nor one of the "
        f"Census Bureau's symbols ({SYMBOLS})"
    )


# -- what the tables describe --------------------------------------------------------


def describe(tables: Sequence[CensusTable]) -> dict[str, Attribute]:
    """Each estimate as an attribute: a readable label (unique across ``tables``), its
    kind and its margin's column."""
    entries = [(t, code) for t in tables for code in t.estimates]
    labels = _readable([(t.labels[code], t.table) for t, code in entries])
    return {
        code: Attribute(
            key=code, label=label, kind=_kind(t.labels[code]), margin=t.margins.get(code)
        )
        for (t, code), label in zip(entries, labels, strict=True)
    }


def _segments(label: str) -> tuple[bool, list[str]]:
    """Whether a label is a percentage, and its meaningful "!!" segments, cleaned:
    ``Estimate!!Total:!!Male:!!Under 5 years`` -> Male, Under 5 years."""
    parts = [
        " ".join(p.split()).removesuffix("--").strip().rstrip(":").strip()
        for p in _plain(label).split("!!")
    ]
    parts = [p for p in parts if p]
    percent = bool(parts) and parts[0].lower() == "percent"
    if parts and parts[0].lower() in ("estimate", "percent"):
        parts = parts[1:]
    meaningful = [p for p in parts if p.lower() != "total"]
    return percent, meaningful


def _readable(labels: Sequence[tuple[str, str]]) -> list[str]:
    """The last meaningful segment of each label; where two read alike, more segments,
    then "(%)" on percentages, then the table id, until they differ."""
    parsed = [_segments(label) for label, _ in labels]

    def name(index: int, level: int) -> str:
        percent, segments = parsed[index]
        depth = min(level + 1, len(segments))
        text = ": ".join(segments[-depth:]) if segments else "Total"
        steps = level + 1 - len(segments)  # levels past the segments
        if percent and steps >= 1:
            text += " (%)"
        table = labels[index][1]
        if table and (not segments or steps >= 2):
            text += f" ({table})"
        return _shortened(text)

    levels = [0] * len(labels)
    for _ in range(max((len(s) for _, s in parsed), default=0) + 3):
        names = [name(i, level) for i, level in enumerate(levels)]
        alike: defaultdict[str, list[int]] = defaultdict(list)
        for index, text in enumerate(names):
            alike[text].append(index)
        clashes = [group for group in alike.values() if len(group) > 1]
        if not clashes:
            break
        for group in clashes:
            for index in group:
                levels[index] += 1
    return [name(i, level) for i, level in enumerate(levels)]


def _shortened(text: str) -> str:
    if len(text) <= LABEL_LENGTH:
        return text
    return text[: LABEL_LENGTH - 1].rsplit(" ", 1)[0] + "…"


def _kind(label: str) -> Kind:
    """count | money | number | percent, as the label says."""
    percent, segments = _segments(label)
    text = _plain(label).lower()
    if percent or (segments and segments[0].lower().startswith("percent")):
        return "percent"
    if "dollars" in text:
        return "money"
    if any(word in text for word in ("median", "mean", "average", "ratio", "index", "per ")):
        return "number"
    return "count"


def source_of(tables: Iterable[CensusTable]) -> tuple[str, str]:
    """A title and a source line for the data set, from the tables' file names:
    ("ACS 5-year estimates 2018-2022: B01003, B19013", "US Census Bureau, ...")."""
    tables = list(tables)
    products = sorted({t.product for t in tables if t.product})
    ids = ", ".join(t.table or t.name for t in tables)
    described = [_product(p) for p in products]
    title = f"{'; '.join(described)}: {ids}" if described else f"Census tables {ids}"
    files = ", ".join(f"{t.product}.{t.table}" if t.product else t.name for t in tables)
    source = f"US Census Bureau, data.census.gov: {files}. Public domain."
    return _shortened(title), source[:SOURCE_LENGTH]


def _product(product: str) -> str:
    """ "ACSDT5Y2022" -> "ACS 5-year estimates 2018-2022"."""
    match = PRODUCT.fullmatch(product)
    if not match:
        return product
    years, year = int(match.group("years")), int(match.group("year"))
    span = f"{year - years + 1}-{year}" if years > 1 else str(year)
    return f"ACS {years}-year estimates {span}"
