"""Census data sets from files: tract outlines (a shapefile, a zipped shapefile as
TIGER/Line ships them, or a GeoJSON FeatureCollection) joined by key to optional
tables of values (CSV, or the Census Bureau's own downloads, see :mod:`acs`),
checked, repaired where possible, then stored whole.

Everything is read and checked before anything is written, so a refused import
leaves the database as it was; the only write is :func:`store.save`'s transaction.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import struct
import tomllib
import warnings
import zipfile
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any

import shapefile
import shapely
from pydantic import ValidationError
from shapely import MultiPolygon, Polygon
from shapely.errors import ShapelyError
from shapely.geometry import mapping, shape
from sqlalchemy.exc import IntegrityError

from webapp.apps.census_map import acs, store
from webapp.apps.census_map.dataset import Attribute, DataSetSettings, Value, default_settings
from webapp.database.connection import Database

LISTED = 20  # keys listed per kind of problem; the rest are counted
MISSING_TEXT = frozenset({"", "na", "n/a", "-", "null"})
INTEGER = re.compile(r"[+-]?\d+")
PROJECTED = re.compile(r'^\s*PROJ(?:CS|CRS)\s*\[\s*"([^"]*)"', re.IGNORECASE)
SHAPEFILE_PARTS = (".shp", ".shx", ".dbf", ".prj", ".cpg")
PART_HEADERS = {".shp": 100, ".shx": 100, ".dbf": 32}  # bytes, up to what declares the size
GEOJSON_SUFFIXES = (".geojson", ".json")
NAME_LENGTH = 64  # census_datasets.name
# The text column taken for the tracts' names when the settings name none (a GeoJSON's
# or CSV's NAME: "Foggy Bottom"); a Census Bureau table's NAME names counties instead.
NAME_COLUMNS = ("NAME",)
TRACT_NAME_LENGTH = 120


class CensusImportError(Exception):
    """An import refused, with a message for the person who asked for it."""


@dataclass(frozen=True)
class ImportReport:
    """What an import stored and what it had to leave out or change."""

    dataset_id: int
    name: str
    tracts: int
    attributes: tuple[str, ...]
    unmatched_shapes: tuple[str, ...]  # shape keys without a table row
    unmatched_rows: tuple[str, ...]  # table keys without a shape
    repaired: tuple[tuple[str, str], ...]  # (key, why the outline was invalid)
    skipped: tuple[tuple[str, str], ...]  # (key, why the tract was left out)
    ignored_columns: tuple[str, ...] = ()  # not numeric, so not attributes
    margins: tuple[str, ...] = ()  # columns stored as attributes' margins of error
    name_column: str | None = None  # the text column the tracts' names came from
    named: int = 0  # how many tracts it named

    def lines(self) -> list[str]:
        """The summary a person reads: counts first, then the keys behind each problem."""
        lines = [
            f"imported data set {self.dataset_id} {self.name!r}: {self.tracts} tracts, "
            f"{len(self.attributes)} attributes",
            f"  shapes without a table row: {len(self.unmatched_shapes)}, "
            f"table rows without a shape: {len(self.unmatched_rows)}, "
            f"outlines repaired: {len(self.repaired)}, tracts skipped: {len(self.skipped)}",
            f"attributes: {listed(self.attributes)}",
        ]
        if self.margins:
            lines.append(f"margins of error: {listed(self.margins)}")
        if self.name_column:
            lines.append(
                f"tract names: {self.name_column} ({self.named} of {self.tracts} tracts named)"
            )
        if self.ignored_columns:
            lines.append(f"left out, not numeric: {listed(self.ignored_columns)}")
        return lines + problem_lines(
            self.unmatched_shapes, self.unmatched_rows, self.repaired, self.skipped
        )


def listed(items: Sequence[str], limit: int = LISTED) -> str:
    more = f" and {len(items) - limit} more" if len(items) > limit else ""
    return ", ".join(items[:limit]) + more


def problem_lines(
    unmatched_shapes: Sequence[str],
    unmatched_rows: Sequence[str],
    repaired: Sequence[tuple[str, str]],
    skipped: Sequence[tuple[str, str]],
) -> list[str]:
    """One line per kind of problem, naming up to :data:`LISTED` keys each."""
    kinds = [
        ("shapes without a table row", list(unmatched_shapes)),
        ("table rows without a shape", list(unmatched_rows)),
        ("outlines repaired", [f"{key} ({why})" for key, why in repaired]),
        ("tracts skipped", [f"{key} ({why})" for key, why in skipped]),
    ]
    return [f"{kind}: {listed(items)}" for kind, items in kinds if items]


@dataclass(frozen=True)
class _Feature:
    """A shape as read: its key, GeoJSON geometry (None: a null shape), properties."""

    key: str
    geometry: Mapping[str, Any] | None
    properties: Mapping[str, Any]


def import_files(
    db: Database,
    *,
    shapes: Path,
    key: str,
    tables: Sequence[Path] = (),
    settings: Path | None = None,
    name: str | None = None,
    strict: bool = False,
) -> ImportReport:
    """Import ``shapes`` (joined to ``tables`` by ``key`` when given) as a new data set
    and make it current; :class:`CensusImportError` says why when it cannot."""
    name = name or shapes.stem
    if not 1 <= len(name) <= NAME_LENGTH:
        raise CensusImportError(f"a data set name has 1 to {NAME_LENGTH} characters: {name!r}")
    settings_file = settings or _beside(shapes)
    chosen = _read_settings(settings_file) if settings_file else None
    features = _read_shapes(shapes, key)
    _refuse_duplicates(shapes.name, [f.key for f in features])
    if tables:
        # Census Bureau tables name tracts by GEO_ID: 1400000US06067000100 joins the
        # shapes' 06067000100, or the whole GEO_ID where the shapes hold those.
        table = _read_tables(tables, key, full_ids=any("US" in f.key for f in features))
    else:
        columns = list(dict.fromkeys(c for f in features for c in f.properties if c != key))
        table = _Table(columns, {f.key: f.properties for f in features})
    records = table.records

    shape_keys = {f.key for f in features}
    unmatched_shapes = tuple(sorted(shape_keys - records.keys()))
    unmatched_rows = tuple(sorted(records.keys() - shape_keys))
    joined = [f for f in features if f.key in records]
    attributes = _numeric_columns(table.columns, [records[f.key] for f in joined])
    margins = [table.margins[a] for a in attributes if a in table.margins]
    tracts = _tracts(joined, records, [*attributes, *margins])
    rows = tracts.rows
    repaired, skipped = tracts.repaired, tracts.skipped
    problems = problem_lines(unmatched_shapes, unmatched_rows, repaired, skipped)
    if strict and problems:
        raise CensusImportError("\n".join(["strict import refused, nothing imported:", *problems]))
    if not rows:
        raise CensusImportError(_nothing_left(key, features, records, skipped))
    _require_longitude_latitude(shapes.name, tracts.outlines)
    if not attributes:
        raise CensusImportError(f"no numeric columns to show besides {key!r}")
    chosen = chosen or _generated_settings(table.title or shapes.stem, attributes, table)
    _require_known_attributes(chosen, attributes, margins, settings_file)
    stored_keys = {row.geoid for row in rows}
    name_column = _name_column(chosen, table, joined, attributes, settings_file)
    names = _tract_names(name_column, [f for f in joined if f.key in stored_keys], records)
    if name_column:
        chosen = chosen.model_copy(update={"name_column": name_column, "names": names})
    source = " + ".join(p.name for p in (shapes, *tables))
    dataset_id = store.save(db, name, chosen, rows, source=source)
    return ImportReport(
        dataset_id=dataset_id,
        name=name,
        tracts=len(rows),
        attributes=tuple(attributes),
        unmatched_shapes=unmatched_shapes,
        unmatched_rows=unmatched_rows,
        repaired=tuple(repaired),
        skipped=tuple(skipped),
        ignored_columns=tuple(
            [
                *table.left_out,
                *(c for c in table.columns if c not in attributes and c != name_column),
            ]
        ),
        margins=tuple(margins),
        name_column=(
            name_column
            if name_column is None or name_column in table.columns
            else f"{name_column} of the shapes"
        ),
        named=len(names),
    )


def _name_column(
    chosen: DataSetSettings,
    table: _Table,
    joined: Sequence[_Feature],
    attributes: Sequence[str],
    settings_file: Path | None,
) -> str | None:
    """The column that names the tracts: the settings' ``name_column`` (which the data
    must have), else the first of :data:`NAME_COLUMNS` that holds text, else none."""
    columns = list(dict.fromkeys([*table.columns, *(c for f in joined for c in f.properties)]))
    if chosen.name_column:
        if chosen.name_column not in columns:
            raise CensusImportError(
                f"{settings_file or 'the settings'} names the tracts by column "
                f"{chosen.name_column!r}, which the data lack (columns: {listed(columns)})"
            )
        return chosen.name_column
    return next(
        (
            c
            for c in NAME_COLUMNS
            if c in columns and c not in attributes and _holds_text(c, joined, table.records)
        ),
        None,
    )


def _holds_text(
    column: str, features: Sequence[_Feature], records: Mapping[str, Mapping[str, Any]]
) -> bool:
    """Whether ``column`` holds text, not only numbers (TIGER/Line's NAME is the tract
    number, "220.01": no name)."""
    for feature in features:
        try:
            _number(_cell(column, feature, records))
        except ValueError:
            return True
    return False


def _cell(column: str, feature: _Feature, records: Mapping[str, Mapping[str, Any]]) -> Any:
    """``column`` of a tract: the table's, else the shape's own."""
    record = records.get(feature.key, {})
    return record[column] if column in record else feature.properties.get(column)


def _tract_names(
    column: str | None, features: Sequence[_Feature], records: Mapping[str, Mapping[str, Any]]
) -> dict[str, str]:
    """Each tract's name in ``column`` (the table's, else the shape's own), by key;
    tracts whose cell is empty go unnamed."""
    if column is None:
        return {}
    names = {}
    for feature in features:
        raw = _cell(column, feature, records)
        text = " ".join(str(raw).split()) if raw is not None else ""
        if text:
            names[feature.key] = text[:TRACT_NAME_LENGTH]
    return names


@dataclass
class _Table:
    """Values by key from one or more tables: the columns that may become attributes,
    in order, and what Census Bureau tables add (margins, descriptions, a title)."""

    columns: list[str]
    records: Mapping[str, Mapping[str, Any]]
    margins: dict[str, str] = field(default_factory=dict)  # column -> its margin's column
    described: dict[str, Attribute] = field(default_factory=dict)
    left_out: list[str] = field(default_factory=list)  # text columns the tables name
    counties: dict[str, str] = field(default_factory=dict)  # county FIPS -> name
    title: str = ""
    source: str = ""


@dataclass
class _Tracts:
    """The joined features as tract rows, with what was repaired or skipped and why."""

    rows: list[store.TractRow] = field(default_factory=list)
    outlines: list[Any] = field(default_factory=list)
    repaired: list[tuple[str, str]] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)


def _tracts(
    joined: list[_Feature], records: Mapping[str, Mapping[str, Any]], attributes: list[str]
) -> _Tracts:
    tracts = _Tracts()
    for feature in joined:
        outline, problem = _outline(feature.geometry)
        if outline is None:
            tracts.skipped.append((feature.key, problem or "no outline"))
            continue
        if problem:
            tracts.repaired.append((feature.key, problem))
        record = records[feature.key]
        values = {column: _number(record.get(column)) for column in attributes}
        tracts.rows.append(store.TractRow(feature.key, _geojson(outline), values))
        tracts.outlines.append(outline)
    return tracts


def _generated_settings(title: str, attributes: list[str], table: _Table) -> DataSetSettings:
    try:
        return default_settings(title, attributes, table.described, table.source, table.counties)
    except ValidationError as error:
        problems = "; ".join(
            f"{'.'.join(str(part) for part in p['loc']) or 'settings'} "
            f"{str(p['input'])[:40]!r}: {p['msg']}"
            for p in error.errors()[:3]
        )
        raise CensusImportError(
            f"the columns cannot become settings ({problems}); give settings of your own "
            f"with --settings"
        ) from error


def _require_known_attributes(
    chosen: DataSetSettings, attributes: list[str], margins: list[str], settings_file: Path | None
) -> None:
    unknown = [a.key for a in chosen.attributes if a.key not in attributes]
    if unknown:
        raise CensusImportError(
            f"{settings_file or 'the settings'} names attributes the data lack: {listed(unknown)}"
            f" (numeric columns: {listed(attributes)})"
        )
    stored = {*attributes, *margins}
    lacking = [
        f"{a.margin} (of {a.key})" for a in chosen.attributes if a.margin not in {None, *stored}
    ]
    if lacking:
        raise CensusImportError(
            f"{settings_file or 'the settings'} names margins of error the data lack: "
            f"{listed(lacking)}"
        )


# -- settings ------------------------------------------------------------------------


def _beside(shapes: Path) -> Path | None:
    """The settings an instructor keeps next to the shapes (same name, ``.toml``)."""
    candidate = shapes.with_suffix(".toml")
    return candidate if candidate.is_file() else None


def _read_settings(path: Path) -> DataSetSettings:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise CensusImportError(f"cannot read settings {path}: {error.strerror}") from error
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise CensusImportError(f"{path} is not valid TOML: {error}") from error
    try:
        return DataSetSettings.model_validate(data)
    except ValidationError as error:
        problems = [
            f"  {'.'.join(str(part) for part in p['loc']) or 'settings'}: {p['msg']}"
            for p in error.errors()
        ]
        raise CensusImportError("\n".join([f"{path}: invalid settings", *problems])) from error


# -- shapes ----------------------------------------------------------------------------


def _read_shapes(path: Path, key: str) -> list[_Feature]:
    if not path.is_file():
        raise CensusImportError(f"no such file: {path}")
    suffix = path.suffix.lower()
    if suffix == ".shp":
        return _read_shapefile(path.name, _shapefile_beside(path), key)
    if suffix == ".zip":
        return _read_shapefile(path.name, _shapefile_in_zip(path), key)
    if suffix in GEOJSON_SUFFIXES:
        return _read_geojson(path, key)
    raise CensusImportError(
        f"{path.name}: not a kind of file the census import reads; give a .shp (with its "
        f".dbf beside it), a .zip holding one shapefile, or a .geojson FeatureCollection"
    )


def _shapefile_beside(path: Path) -> dict[str, bytes]:
    """The parts of the shapefile ``path`` by suffix (``.shp``, ``.dbf``, ...)."""
    return {
        part.suffix.lower(): part.read_bytes()
        for part in path.parent.iterdir()
        if part.stem == path.stem and part.suffix.lower() in SHAPEFILE_PARTS and part.is_file()
    }


def _shapefile_in_zip(path: Path) -> dict[str, bytes]:
    """The parts of the one shapefile in a zip (in a folder or not), read in memory."""
    try:
        with zipfile.ZipFile(path) as archive:
            members = [
                PurePosixPath(m)
                for m in archive.namelist()
                if not m.startswith("__MACOSX/") and not m.endswith("/")
            ]
            shps = [m for m in members if m.suffix.lower() == ".shp"]
            if len(shps) != 1:
                found = listed([str(m) for m in shps]) if shps else "none"
                raise CensusImportError(
                    f"{path.name}: a zip must hold exactly one shapefile (.shp found: {found})"
                )
            stem = shps[0].with_suffix("")
            return {
                m.suffix.lower(): archive.read(str(m))
                for m in members
                if m.with_suffix("") == stem and m.suffix.lower() in SHAPEFILE_PARTS
            }
    except (zipfile.BadZipFile, OSError) as error:
        raise CensusImportError(f"{path.name}: not a readable zip file: {error}") from error


def _read_shapefile(label: str, parts: Mapping[str, bytes], key: str) -> list[_Feature]:
    if ".dbf" not in parts:
        raise CensusImportError(f"{label}: the shapefile's .dbf (its table) is missing")
    _refuse_projected(label, parts.get(".prj"))
    _refuse_cut_short(label, parts)
    files = {suffix.lstrip("."): io.BytesIO(data) for suffix, data in parts.items()}
    files.pop("prj", None)
    try:
        # Text columns other than the key are left out anyway, so a wrong code page
        # must not stop an import: undecodable bytes are replaced. pyshp's warnings (a
        # header's size, pad bytes, a .cpg) are its asides, printed with its path in
        # site-packages: what an import must know is checked here, said in its words.
        with (
            warnings.catch_warnings(action="ignore"),
            shapefile.Reader(**files, encodingErrors="replace") as reader,
        ):
            # fields[0] is the deletion flag; a field is [name, type, size, decimals]
            columns = [field[0] for field in reader.fields[1:]]
            if key not in columns:
                raise CensusImportError(_no_key_column(label, key, columns))
            features = [
                _feature(label, index, key, _shape_geometry(item.shape), item.record.as_dict())
                for index, item in enumerate(reader.iterShapeRecords(), start=1)
            ]
    except (shapefile.ShapefileException, struct.error, ValueError, EOFError) as error:
        raise CensusImportError(f"{label}: not a readable shapefile: {error}") from error
    return features


def _declared_size(suffix: str, data: bytes) -> int:
    """The bytes a shapefile part's whole header says it holds: the file length in
    16-bit words of a .shp's or .shx's, a .dbf's header and record lengths times its
    records."""
    if suffix == ".dbf":
        records, header, record = struct.unpack_from("<IHH", data, 4)
        return int(header + records * record)
    return int(struct.unpack_from(">i", data, 24)[0]) * 2


def _refuse_cut_short(label: str, parts: Mapping[str, bytes]) -> None:
    """A part shorter than its header says is a copy or download cut off: refused
    before pyshp reads it (which warns, then fails on a struct it cannot unpack)."""
    for suffix, header in PART_HEADERS.items():
        data = parts.get(suffix)
        if data is None:
            continue
        if len(data) < header:
            said = f"{len(data):,} bytes, less than its {header}-byte header"
        elif len(data) < (declared := _declared_size(suffix, data)):
            said = f"its header declares {declared:,} bytes, the file holds {len(data):,}"
        else:
            continue
        raise CensusImportError(
            f"{label}: its {suffix} is cut short: {said} (copy or download it again)"
        )


def _shape_geometry(item: Any) -> Mapping[str, Any] | None:
    """A shapefile shape as GeoJSON; types GeoJSON lacks (MultiPatch) by name only."""
    if item.shapeType == shapefile.NULL:
        return None
    try:
        geometry: Mapping[str, Any] = item.__geo_interface__
    except shapefile.GeoJSON_Error:
        return {"type": item.shapeTypeName}
    return geometry


def _refuse_projected(label: str, prj: bytes | None) -> None:
    """Outlines must be longitude/latitude: a projected CRS (metres or feet) is refused
    rather than guessed at. A missing .prj is taken as longitude/latitude."""
    match = PROJECTED.match(prj.decode("utf-8", errors="replace")) if prj else None
    if match:
        raise CensusImportError(
            f"{label}: its .prj describes a projected coordinate system ({match.group(1)}), "
            f"but the census map needs longitude/latitude; reproject first, e.g. "
            f"`ogr2ogr -t_srs EPSG:4326 out.shp in.shp`"
        )


def _read_geojson(path: Path, key: str) -> list[_Feature]:
    try:
        data = json.loads(path.read_bytes())
    except (ValueError, OSError) as error:
        raise CensusImportError(f"{path.name}: not readable JSON: {error}") from error
    collection = data if isinstance(data, dict) else {}
    items = collection.get("features")
    if collection.get("type") != "FeatureCollection" or not isinstance(items, list):
        raise CensusImportError(f"{path.name}: not a GeoJSON FeatureCollection")
    features = [item if isinstance(item, dict) else {} for item in items]
    properties = [f.get("properties") or {} for f in features]
    if features and not any(key in p for p in properties):
        columns = list(dict.fromkeys(c for p in properties for c in p))
        raise CensusImportError(_no_key_column(path.name, key, columns))
    return [
        _feature(path.name, index, key, feature.get("geometry"), props)
        for index, (feature, props) in enumerate(zip(features, properties, strict=True), start=1)
    ]


def _feature(
    label: str, index: int, key: str, geometry: Any, properties: Mapping[str, Any]
) -> _Feature:
    value = _key(properties.get(key))
    if not value:
        raise CensusImportError(f"{label}: shape {index} has no {key} value")
    return _Feature(value, geometry if isinstance(geometry, Mapping) else None, properties)


def _no_key_column(label: str, key: str, columns: Sequence[str]) -> str:
    return f"{label} has no column {key!r}; its columns: {listed(columns) or 'none'}"


def _key(value: object) -> str:
    """A join key as text: numbers (a dbf's N column, JSON) as their digits, no ".0"."""
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return "" if value is None else str(value).strip()


def _refuse_duplicates(label: str, keys: Iterable[str]) -> None:
    twice = sorted(k for k, n in Counter(keys).items() if n > 1)
    if twice:
        raise CensusImportError(f"{label}: keys that appear more than once: {listed(twice)}")


# -- outlines --------------------------------------------------------------------------


def _outline(geometry: Mapping[str, Any] | None) -> tuple[Any, str | None]:
    """A shape's outline as a 2-D Polygon or MultiPolygon, and the problem met:
    ``(outline, None)`` valid, ``(outline, reason)`` repaired, ``(None, reason)`` skipped.
    """
    if geometry is None:
        return None, "no outline"
    kind = geometry.get("type")
    if kind not in ("Polygon", "MultiPolygon"):
        return None, f"not a polygon but {kind or 'nothing'}"
    try:
        outline = shapely.force_2d(shape(geometry))
    except (ValueError, TypeError, IndexError, ShapelyError) as error:
        return None, f"unreadable outline: {error}"
    if outline.is_empty:
        return None, "empty outline"
    if shapely.is_valid(outline):
        return outline, None
    reason = str(shapely.is_valid_reason(outline))
    fixed = _polygonal(shapely.make_valid(outline))
    if fixed is None:
        return None, f"invalid ({reason}) and nothing of it is left once repaired"
    return fixed, reason


def _polygonal(geometry: Any) -> Any:
    """The polygon parts of a repaired geometry (make_valid may add lines and points
    where a ring collapsed), or None when there are none."""
    polygons = [
        polygon
        for part in shapely.get_parts(geometry)
        for polygon in shapely.get_parts(part)
        if isinstance(polygon, Polygon) and not polygon.is_empty
    ]
    if not polygons:
        return None
    result = polygons[0] if len(polygons) == 1 else MultiPolygon(polygons)
    return result if shapely.is_valid(result) else None


def _geojson(outline: Any) -> dict[str, Any]:
    """A GeoJSON dict with lists for coordinates (``mapping`` gives tuples)."""
    geometry: dict[str, Any] = json.loads(json.dumps(mapping(outline)))
    return geometry


def _require_longitude_latitude(label: str, outlines: Sequence[Any]) -> None:
    """Catch projected coordinates that came without a .prj to say so."""
    bounds = shapely.total_bounds(outlines)
    west, south, east, north = (float(b) for b in bounds)
    if west < -180 or east > 180 or south < -90 or north > 90:
        raise CensusImportError(
            f"{label}: coordinates run from ({west:g}, {south:g}) to ({east:g}, {north:g}), "
            f"so they are not longitude/latitude; reproject to EPSG:4326 first"
        )


# -- table and values ------------------------------------------------------------------


def _read_tables(paths: Sequence[Path], key: str, *, full_ids: bool) -> _Table:
    """The tables' values merged by key: a column may come from one table only."""
    merged = _Table([], {})
    records: dict[str, dict[str, Any]] = {}
    census: list[acs.CensusTable] = []
    owner: dict[str, str] = {}
    for path in paths:
        if acs.is_census_table(path):
            try:
                read = acs.read(path, full_ids=full_ids)
            except acs.TableError as error:
                raise CensusImportError(str(error)) from error
            census += read
            parts = [(t.name, t.estimates, t.records, [*t.margins.values()]) for t in read]
            merged.margins.update(m for t in read for m in t.margins.items())
            merged.left_out += [c for t in read for c in t.left_out if c not in merged.left_out]
            merged.counties.update(c for t in read for c in t.counties.items())
        else:
            columns, rows = _read_table(path, key)
            parts = [(path.name, columns, rows, [])]
        for label, columns, rows, margins in parts:
            for column in [*columns, *margins]:
                if column in owner:
                    raise CensusImportError(
                        f"column {column} is in both {owner[column]} and {label}: "
                        f"give each column once"
                    )
                owner[column] = label
            merged.columns += columns
            for row_key, row in rows.items():
                records.setdefault(row_key, {}).update(row)
    merged.records = records
    if census:
        merged.described = acs.describe(census)
        merged.title, merged.source = acs.source_of(census)
    return merged


def _read_table(path: Path, key: str) -> tuple[list[str], dict[str, dict[str, Any]]]:
    """The table's columns, and its rows by key (keys unique)."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as file:
            reader = csv.DictReader(file)
            columns = [c.strip() for c in reader.fieldnames or []]
            reader.fieldnames = columns
            if key not in columns:
                raise CensusImportError(_no_key_column(path.name, key, columns))
            twice = sorted(c for c, n in Counter(columns).items() if n > 1)
            if twice:
                raise CensusImportError(f"{path.name}: columns named twice: {listed(twice)}")
            rows = list(reader)
    except OSError as error:
        raise CensusImportError(f"cannot read {path}: {error.strerror}") from error
    except (UnicodeDecodeError, csv.Error) as error:
        raise CensusImportError(f"{path.name}: not a UTF-8 CSV file: {error}") from error
    for line, row in enumerate(rows, start=2):
        if not _key(row.get(key)):
            raise CensusImportError(f"{path.name}: row {line} has no {key} value")
    _refuse_duplicates(path.name, [_key(row[key]) for row in rows])
    return [c for c in columns if c != key], {_key(row[key]): row for row in rows}


def _numeric_columns(columns: Sequence[str], records: Sequence[Mapping[str, Any]]) -> list[str]:
    """The columns whose values (in the rows that join a shape) are all numbers or
    missing, with at least one number: the attributes. Text such as a NAME is left out,
    and so are rows that never join, such as a second header line of labels."""
    numeric = []
    for column in columns:
        try:
            values = [_number(record.get(column)) for record in records]
        except ValueError:
            continue
        if any(v is not None for v in values):
            numeric.append(column)
    return numeric


def _number(raw: object) -> Value:
    """A cell as a number (an int stays an int); None when missing or an ACS jam value;
    ValueError when it is text."""
    if raw is None:
        return None
    if isinstance(raw, bool) or not isinstance(raw, int | float | str):
        raise ValueError(f"not a number: {raw!r}")
    if isinstance(raw, str):
        text = raw.strip()
        if text.lower() in MISSING_TEXT:
            return None
        number: float = int(text) if INTEGER.fullmatch(text) else float(text)
    else:
        number = raw
    return None if not math.isfinite(number) or number in acs.JAM_VALUES else number


def _nothing_left(
    key: str,
    features: Sequence[_Feature],
    records: Mapping[str, Any],
    skipped: Sequence[tuple[str, str]],
) -> str:
    """Why no tract is left, with the keys side by side when none matched (a key that
    lost its leading zero in a spreadsheet is the usual cause)."""
    if not features:
        return "the shapes hold no features; nothing imported"
    if skipped:
        return "every matched tract was skipped, nothing imported: " + "; ".join(
            problem_lines((), (), (), skipped)
        )
    sample_rows = listed(sorted(records)[:3], 3) or "none"
    return (
        f"no shape matched a table row by {key}, nothing imported (shapes: "
        f"{listed([f.key for f in features[:3]], 3)}; table: {sample_rows})"
    )


def seed(db: Database, path: Path = store.SHIPPED) -> int | None:
    """Import the shipped data set when the database holds none (the demo's default).

    Several server processes may start at once: the one whose data set the database
    turns away (one current data set at most) shows the one that got in.
    """
    if store.count(db):
        return None
    try:
        return import_files(db, shapes=path, key=store.SHIPPED_KEY).dataset_id
    except IntegrityError:
        return store.current_id(db)
