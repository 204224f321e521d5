"""The census importer on real files: shapefiles (loose and zipped), GeoJSON, CSV tables."""

from __future__ import annotations

import json
import threading
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
import shapefile
import shapely
from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from webapp.apps.census_map import importer, store
from webapp.apps.census_map.importer import CensusImportError, ImportReport, import_files
from webapp.core.settings import Settings
from webapp.database.connection import Database
from webapp.database.models import CensusDataSetRecord, CensusTractRecord

KEYS = ("06067000100", "06067000200", "06067000300")
NAD83_UTM = (
    'PROJCS["NAD_1983_UTM_Zone_10N",GEOGCS["GCS_North_American_1983",'
    'DATUM["D_North_American_1983",SPHEROID["GRS_1980",6378137.0,298.257222101]],'
    'PRIMEM["Greenwich",0.0],UNIT["Degree",0.0174532925199433]],'
    'PROJECTION["Transverse_Mercator"],UNIT["Meter",1.0]]'
)
NAD83 = (
    'GEOGCS["GCS_North_American_1983",DATUM["D_North_American_1983",'
    'SPHEROID["GRS_1980",6378137,298.257222101]],PRIMEM["Greenwich",0],'
    'UNIT["Degree",0.017453292519943295]]'
)


def square(index: int, size: float = 0.01) -> list[list[float]]:
    """A clockwise ring (a shapefile's exterior) near Sacramento, one per index."""
    x, y = -121.5 + index * size, 38.5
    return [[x, y], [x, y + size], [x + size, y + size], [x + size, y], [x, y]]


BOW_TIE = [[-121.5, 38.5], [-121.49, 38.51], [-121.49, 38.5], [-121.5, 38.51], [-121.5, 38.5]]


def polygon(ring: list[list[float]]) -> dict[str, Any]:
    return {"type": "Polygon", "coordinates": [ring]}


def write_geojson(path: Path, features: list[tuple[str, Any, dict[str, Any]]]) -> Path:
    """A FeatureCollection of (GEOID, geometry, other properties)."""
    collection = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"GEOID": key, **props}, "geometry": geometry}
            for key, geometry, props in features
        ],
    }
    path.write_text(json.dumps(collection))
    return path


def three_tracts(path: Path) -> Path:
    return write_geojson(
        path,
        [
            (key, polygon(square(i)), {"POP": 100 * (i + 1), "NAME": f"T{i}"})
            for i, key in enumerate(KEYS)
        ],
    )


def write_shapefile(
    stem: Path, keys: tuple[str, ...] = KEYS, prj: str | None = None, numeric_key: bool = False
) -> Path:
    """A polygon shapefile (.shp .shx .dbf, and .prj when given) with GEOID and NAME."""
    with shapefile.Writer(str(stem), shapeType=shapefile.POLYGON) as writer:
        if numeric_key:
            writer.field("GEOID", "N", size=18, decimal=2)
        else:
            writer.field("GEOID", "C", size=11)
        writer.field("NAME", "C", size=40)
        for i, key in enumerate(keys):
            writer.poly([square(i)])
            writer.record(float(key) if numeric_key else key, f"Census Tract {i + 1}")
    if prj is not None:
        stem.with_suffix(".prj").write_text(prj)
    return stem.with_suffix(".shp")


def write_csv(path: Path, text: str, bom: bool = False) -> Path:
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    return path


TABLE = (
    "GEOID,NAME,POP,INCOME\n06067000100,One,1200,52000.5\n06067000200,Two,800,\n"
    "06067000300,Three,950,61000\n"
)


def test_the_shipped_data_set_imports_cleanly_and_becomes_current(db: Database) -> None:
    dataset_id = importer.seed(db)
    assert dataset_id is not None and importer.seed(db) is None  # seeded once only
    assert store.current_id(db) == dataset_id
    dataset = store.load(db, dataset_id)
    assert dataset is not None and len(dataset.tracts) == 403
    assert dataset.title == "Sacramento MSA census tracts, 2000"  # the TOML beside it
    assert len(dataset.tracts[0].values) == 27
    report = import_files(db, shapes=store.SHIPPED, key="GEOID", name="again")
    assert (report.tracts, len(report.attributes)) == (403, 27)
    assert report.unmatched_shapes == report.unmatched_rows == ()
    assert report.repaired == report.skipped == ()
    assert store.current_id(db) == report.dataset_id


def test_a_server_seeds_the_data_set_of_its_content_folder(tmp_path: Path) -> None:
    (tmp_path / "census").mkdir()
    ours = Settings(content_dir=tmp_path)
    assert store.first_dataset(ours) == tmp_path / "census" / store.SHIPPED_NAME
    # a content folder without census/ keeps the shipped data set
    assert store.first_dataset(Settings(content_dir=tmp_path / "census")) == store.SHIPPED


def test_the_database_keeps_one_current_data_set(db: Database) -> None:
    importer.seed(db)
    with pytest.raises(IntegrityError), db.session() as session:
        session.add(CensusDataSetRecord(name="second", settings={}, tract_count=0, current=True))


def test_server_processes_seeding_at_once_leave_one_current_data_set(
    db: Database, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two processes starting together both find no data set and both import the
    shipped one: neither fails, and the map shows one data set."""
    both_looked = threading.Barrier(2, timeout=30)

    def empty_after_both_looked(_: Database) -> int:
        both_looked.wait()
        return 0

    monkeypatch.setattr(store, "count", empty_after_both_looked)
    with ThreadPoolExecutor(2) as pool:
        seeded = list(pool.map(lambda _: importer.seed(db), range(2)))
    with db.session() as session:
        current = session.scalars(
            select(CensusDataSetRecord.id).where(CensusDataSetRecord.current.is_(True))
        ).all()
    assert len(current) == 1 and current[0] in seeded


def test_a_shapefile_joins_a_csv_by_key(db: Database, tmp_path: Path) -> None:
    shapes = write_shapefile(tmp_path / "tracts", prj=NAD83)
    report = import_files(
        db, shapes=shapes, key="GEOID", tables=[write_csv(tmp_path / "t.csv", TABLE)]
    )
    assert (report.name, report.tracts, report.attributes) == ("tracts", 3, ("POP", "INCOME"))
    assert report.ignored_columns == ()  # the text NAME names the tracts
    assert (report.name_column, report.named) == ("NAME", 3)
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None and dataset.title == "tracts"  # default settings
    assert [dataset.tract_title(t) for t in dataset.tracts] == ["One", "Two", "Three"]
    values = {t.geoid: t.values for t in dataset.tracts}
    assert values["06067000100"] == {"POP": 1200, "INCOME": 52000.5}
    assert values["06067000200"] == {"POP": 800, "INCOME": None}
    assert isinstance(values["06067000300"]["POP"], int)
    tract = dataset.tract("06067000100")
    assert tract is not None and tract.shape.equals(shapely.Polygon(square(0)))
    assert [d.source for d in store.list_datasets(db)] == ["tracts.shp + t.csv"]


def test_geometry_is_stored_as_geojson_with_lists(db: Database, tmp_path: Path) -> None:
    report = import_files(
        db,
        shapes=write_shapefile(tmp_path / "tracts"),
        key="GEOID",
        tables=[write_csv(tmp_path / "t.csv", TABLE)],
    )
    with db.session() as session:
        row = session.get(CensusTractRecord, (report.dataset_id, "06067000100"))
        assert row is not None
        assert row.geometry == {"type": "Polygon", "coordinates": [square(0)]}


def test_a_numeric_dbf_key_becomes_its_digits(db: Database, tmp_path: Path) -> None:
    keys = ("6067000100", "6067000200")
    shapes = write_shapefile(tmp_path / "tracts", keys=keys, numeric_key=True)
    table = write_csv(tmp_path / "t.csv", "GEOID,POP\n6067000100,5\n 6067000200 ,6\n")
    report = import_files(db, shapes=shapes, key="GEOID", tables=[table])
    assert report.tracts == 2 and report.unmatched_shapes == report.unmatched_rows == ()


def test_a_zipped_shapefile_in_a_folder_imports(db: Database, tmp_path: Path) -> None:
    shapes = write_shapefile(tmp_path / "tl_2020_06_tract", prj=NAD83)
    archive = tmp_path / "california.zip"
    with zipfile.ZipFile(archive, "w") as zipped:
        zipped.writestr("tl_2020_06_tract/", "")
        for suffix in (".shp", ".shx", ".dbf", ".prj"):
            part = shapes.with_suffix(suffix)
            zipped.write(part, f"tl_2020_06_tract/{part.name}")
        zipped.writestr("__MACOSX/tl_2020_06_tract/._tl_2020_06_tract.shp", "junk")
    table = write_csv(tmp_path / "acs.csv", TABLE)
    report = import_files(db, shapes=archive, key="GEOID", tables=[table])
    assert (report.name, report.tracts, report.attributes) == ("california", 3, ("POP", "INCOME"))
    assert not list(Path.cwd().glob("tl_2020_06_tract*"))  # read in memory, not extracted


def test_a_zip_without_exactly_one_shapefile_is_refused(db: Database, tmp_path: Path) -> None:
    archive = tmp_path / "empty.zip"
    with zipfile.ZipFile(archive, "w") as zipped:
        zipped.writestr("readme.txt", "no shapes here")
    with pytest.raises(CensusImportError, match=r"exactly one shapefile"):
        import_files(db, shapes=archive, key="GEOID")


def test_keys_missing_on_either_side_are_reported(db: Database, tmp_path: Path) -> None:
    table = write_csv(
        tmp_path / "t.csv",
        "GEOID,POP\n06067000200,1\n06067000300,2\n06067999900,3\n06067999800,4\n",
    )
    report = import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    assert report.tracts == 2
    assert report.unmatched_shapes == ("06067000100",)
    assert report.unmatched_rows == ("06067999800", "06067999900")
    lines = report.lines()
    assert "shapes without a table row: 1, table rows without a shape: 2" in lines[1]
    assert "shapes without a table row: 06067000100" in lines
    assert "table rows without a shape: 06067999800, 06067999900" in lines


def test_long_problem_lists_name_twenty_and_count_the_rest(db: Database, tmp_path: Path) -> None:
    rows = "".join(f"9{n:010d},{n}\n" for n in range(25))
    table = write_csv(tmp_path / "t.csv", f"GEOID,POP\n06067000100,1\n{rows}")
    report = import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    line = next(x for x in report.lines() if x.startswith("table rows without a shape:"))
    assert line.count(", ") == 19 and line.endswith(" and 5 more")


@pytest.mark.parametrize("side", ["shapes", "table"])
def test_duplicated_keys_are_refused(db: Database, tmp_path: Path, side: str) -> None:
    keys = (*KEYS, KEYS[1]) if side == "shapes" else KEYS
    shapes = write_shapefile(tmp_path / "s", keys=keys)
    table = write_csv(tmp_path / "t.csv", TABLE + ("06067000300,Again,1,2\n" * (side == "table")))
    with pytest.raises(CensusImportError, match=r"more than once: 06067000[23]00"):
        import_files(db, shapes=shapes, key="GEOID", tables=[table])
    assert store.count(db) == 0


def test_a_bow_tie_is_repaired_and_reported(db: Database, tmp_path: Path) -> None:
    shapes = write_geojson(
        tmp_path / "tie.geojson",
        [(KEYS[0], polygon(square(0)), {"POP": 1}), (KEYS[1], polygon(BOW_TIE), {"POP": 2})],
    )
    report = import_files(db, shapes=shapes, key="GEOID")
    assert report.tracts == 2 and report.skipped == ()
    assert [key for key, _ in report.repaired] == [KEYS[1]]
    assert report.repaired[0][1].startswith("Self-intersection")
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    repaired = dataset.tract(KEYS[1])
    assert repaired is not None and repaired.shape.is_valid
    assert repaired.shape.geom_type == "MultiPolygon" and repaired.shape.area == pytest.approx(5e-5)
    assert any(line.startswith(f"outlines repaired: {KEYS[1]} (Self-") for line in report.lines())


def test_degenerate_null_and_point_shapes_are_skipped(db: Database, tmp_path: Path) -> None:
    x, y = square(3)[0]
    shapes = write_geojson(
        tmp_path / "odd.geojson",
        [
            (KEYS[0], polygon(square(0)), {"POP": 1}),
            ("two-points", polygon([[x, y], [x + 0.01, y + 0.01]]), {"POP": 2}),
            ("there-and-back", polygon([[x, y], [x + 0.01, y + 0.01], [x, y]]), {"POP": 3}),
            ("empty", {"type": "Polygon", "coordinates": []}, {"POP": 4}),
            ("null", None, {"POP": 5}),
            ("point", {"type": "Point", "coordinates": [x, y]}, {"POP": 6}),
        ],
    )
    report = import_files(db, shapes=shapes, key="GEOID")
    assert report.tracts == 1 and report.repaired == ()
    reasons = dict(report.skipped)
    assert reasons.keys() == {"two-points", "there-and-back", "empty", "null", "point"}
    assert reasons["two-points"].startswith("unreadable outline")
    assert reasons["there-and-back"].startswith("invalid (Too few points")
    assert reasons["empty"] == "empty outline" and reasons["null"] == "no outline"
    assert reasons["point"] == "not a polygon but Point"
    assert "tracts skipped: 5" in report.lines()[1]


def test_a_null_shape_in_a_shapefile_is_skipped(db: Database, tmp_path: Path) -> None:
    with shapefile.Writer(str(tmp_path / "s"), shapeType=shapefile.POLYGON) as writer:
        writer.field("GEOID", "C", size=11)
        writer.field("POP", "N", size=9)
        writer.poly([square(0)])
        writer.record(KEYS[0], 10)
        writer.null()
        writer.record(KEYS[1], 20)
    report = import_files(db, shapes=tmp_path / "s.shp", key="GEOID")
    assert report.tracts == 1 and report.skipped == ((KEYS[1], "no outline"),)


def test_a_projected_prj_is_refused(db: Database, tmp_path: Path) -> None:
    shapes = write_shapefile(tmp_path / "utm", prj=NAD83_UTM)
    with pytest.raises(CensusImportError, match=r"projected.*NAD_1983_UTM_Zone_10N.*longitude"):
        import_files(db, shapes=shapes, key="GEOID")


def test_projected_coordinates_without_a_prj_are_refused(db: Database, tmp_path: Path) -> None:
    metres = [[630e3, 4260e3], [630e3, 4261e3], [631e3, 4261e3], [630e3, 4260e3]]
    shapes = write_geojson(tmp_path / "m.geojson", [(KEYS[0], polygon(metres), {"POP": 1})])
    with pytest.raises(CensusImportError, match=r"not longitude/latitude"):
        import_files(db, shapes=shapes, key="GEOID")


def test_strict_mode_refuses_any_problem_and_writes_nothing(db: Database, tmp_path: Path) -> None:
    table = write_csv(tmp_path / "t.csv", "GEOID,POP\n06067000100,1\n06067000200,2\n")
    with pytest.raises(CensusImportError) as refused:
        import_files(
            db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table], strict=True
        )
    assert "strict" in str(refused.value)
    assert "shapes without a table row: 06067000300" in str(refused.value)
    assert store.count(db) == 0
    full = write_csv(tmp_path / "full.csv", TABLE)
    report = import_files(db, shapes=tmp_path / "s.shp", key="GEOID", tables=[full], strict=True)
    assert report.tracts == 3


def first_data_set(db: Database, tmp_path: Path) -> ImportReport:
    report = import_files(db, shapes=three_tracts(tmp_path / "first.geojson"), key="GEOID")
    assert store.current_id(db) == report.dataset_id
    return report


def assert_only(db: Database, first: ImportReport) -> None:
    """Nothing but ``first`` is stored, still current and whole."""
    assert store.current_id(db) == first.dataset_id
    assert [d.name for d in store.list_datasets(db)] == ["first"]
    dataset = store.load(db, first.dataset_id)
    assert dataset is not None and len(dataset.tracts) == 3


def test_settings_naming_an_unknown_attribute_change_nothing(db: Database, tmp_path: Path) -> None:
    first = first_data_set(db, tmp_path)
    settings = tmp_path / "settings.toml"
    settings.write_text(
        'title = "T"\nheadline = ["POP"]\n'
        '[[attributes]]\nkey = "POP"\nlabel = "People"\n'
        '[[attributes]]\nkey = "INCOME"\nlabel = "Income"\n'
    )
    with pytest.raises(CensusImportError, match=r"settings.toml names attributes.*INCOME"):
        import_files(
            db, shapes=three_tracts(tmp_path / "second.geojson"), key="GEOID", settings=settings
        )
    assert_only(db, first)


def test_a_failure_inside_the_transaction_changes_nothing(
    db: Database, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    first = first_data_set(db, tmp_path)
    flush = Session.flush

    def failing_flush(self: Session, objects: Any = None) -> None:
        if any(isinstance(o, CensusTractRecord) for o in self.new):
            raise RuntimeError("disk full")
        flush(self, objects)

    monkeypatch.setattr(Session, "flush", failing_flush)
    with pytest.raises(RuntimeError, match=r"disk full"):
        import_files(db, shapes=three_tracts(tmp_path / "second.geojson"), key="GEOID")
    monkeypatch.undo()
    assert_only(db, first)


DC = ("11001000300", "11001000400", "11001000500")


def test_a_geojson_names_its_tracts_by_its_text_name_column(db: Database, tmp_path: Path) -> None:
    """Issue 31: a GeoJSON's NAME was dropped as "not numeric", so its tracts read
    "Tract 3, 11001"."""
    names = ("Foggy Bottom", "Dupont Circle", "")
    shapes = write_geojson(
        tmp_path / "dc.geojson",
        [
            (key, polygon(square(i)), {"ENROLL": 10 * (i + 1), "NAME": name})
            for i, (key, name) in enumerate(zip(DC, names, strict=True))
        ],
    )
    report = import_files(db, shapes=shapes, key="GEOID")
    assert report.attributes == ("ENROLL",) and report.ignored_columns == ()
    assert "tract names: NAME (2 of 3 tracts named)" in report.lines()
    assert not any("not numeric" in line for line in report.lines())
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    titles = [dataset.tract_title(t) for t in dataset.tracts]
    assert titles == ["Foggy Bottom", "Dupont Circle", "Tract 5, 11001"]


def test_a_name_column_of_numbers_names_no_tract(db: Database, tmp_path: Path) -> None:
    """TIGER/Line's NAME is the tract number ("220.01"): a value, not a name."""
    shapes = write_geojson(
        tmp_path / "tiger.geojson",
        [(key, polygon(square(i)), {"NAME": f"{i + 1}.01"}) for i, key in enumerate(KEYS)],
    )
    report = import_files(db, shapes=shapes, key="GEOID")
    assert report.name_column is None and report.attributes == ("NAME",)
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None and dataset.tract_title(dataset.tracts[0]) == "Tract 1, 06067"


def test_settings_choose_the_name_column(db: Database, tmp_path: Path) -> None:
    shapes = write_geojson(
        tmp_path / "named.geojson",
        [
            (key, polygon(square(i)), {"POP": i, "NAME": "x", "LABEL": f"Ward {i + 1}"})
            for i, key in enumerate(DC)
        ],
    )
    settings = tmp_path / "settings.toml"
    settings.write_text(
        'title = "Wards"\nheadline = ["POP"]\nname_column = "LABEL"\n'
        '[counties]\n"11001" = "District of Columbia"\n'
        '[[attributes]]\nkey = "POP"\nlabel = "People"\n'
    )
    report = import_files(db, shapes=shapes, key="GEOID", settings=settings)
    assert report.name_column == "LABEL" and report.ignored_columns == ("NAME",)
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    assert dataset.tract_title(dataset.tracts[0]) == "Ward 1, District of Columbia"
    settings.write_text(settings.read_text().replace('"LABEL"', '"WARD"'))
    with pytest.raises(CensusImportError, match=r"names the tracts by column 'WARD'"):
        import_files(db, shapes=shapes, key="GEOID", settings=settings)


def test_settings_beside_the_shapes_are_used(db: Database, tmp_path: Path) -> None:
    shapes = three_tracts(tmp_path / "mine.geojson")
    (tmp_path / "mine.toml").write_text(
        'title = "My tracts"\nheadline = ["POP"]\n[[attributes]]\nkey = "POP"\nlabel = "People"\n'
    )
    dataset = store.load(db, import_files(db, shapes=shapes, key="GEOID").dataset_id)
    assert dataset is not None and dataset.title == "My tracts"


def test_invalid_settings_are_refused_naming_the_file(db: Database, tmp_path: Path) -> None:
    settings = tmp_path / "bad.toml"
    settings.write_text('title = ""\nheadline = ["POP"]\n')
    with pytest.raises(CensusImportError) as refused:
        import_files(
            db, shapes=three_tracts(tmp_path / "s.geojson"), key="GEOID", settings=settings
        )
    message = str(refused.value)
    assert "bad.toml: invalid settings" in message and "title:" in message
    assert "attributes: Field required" in message
    settings.write_text("title = = 1")
    with pytest.raises(CensusImportError, match=r"bad.toml is not valid TOML"):
        import_files(db, shapes=tmp_path / "s.geojson", key="GEOID", settings=settings)


def test_a_csv_with_a_bom_and_acs_jam_values(db: Database, tmp_path: Path) -> None:
    table = write_csv(
        tmp_path / "acs.csv",
        "GEOID,NAME,B01003_001E,B19013_001E,B25077_001E,NOTE\n"
        "06067000100,Tract 1,4000,-666666666,N/A,x\n"
        "06067000200,Tract 2,3000,-999999999,-,y\n"
        "06067000300,Tract 3,NA,-888888888.0,,\n",
        bom=True,
    )
    report = import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    assert report.attributes == ("B01003_001E",)  # the others hold no number at all
    assert report.ignored_columns == ("B19013_001E", "B25077_001E", "NOTE")
    assert report.name_column == "NAME"
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    assert [t.values for t in dataset.tracts] == [
        {"B01003_001E": 4000},
        {"B01003_001E": 3000},
        {"B01003_001E": None},
    ]


def test_jam_values_become_none_among_numbers(db: Database, tmp_path: Path) -> None:
    table = write_csv(
        tmp_path / "acs.csv",
        "\ufeffGEOID,INCOME\n06067000100,-222222222\n06067000200,51000\n06067000300,null\n",
    )
    report = import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    assert [t.values["INCOME"] for t in dataset.tracts] == [None, 51000, None]


def test_a_label_row_that_joins_no_shape_does_not_hide_numbers(
    db: Database, tmp_path: Path
) -> None:
    table = write_csv(
        tmp_path / "acs.csv",
        "GEOID,POP\nGeography,Estimate!!Total\n06067000100,1\n06067000200,2\n06067000300,3\n",
    )
    report = import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    assert report.attributes == ("POP",) and report.unmatched_rows == ("Geography",)


@pytest.mark.parametrize(
    "name,message",
    [
        ("tracts.kml", "not a kind of file"),
        ("tracts.csv", "not a kind of file"),
        ("absent.geojson", "no such file"),
    ],
)
def test_unreadable_shape_files_are_refused(
    db: Database, tmp_path: Path, name: str, message: str
) -> None:
    if not name.startswith("absent"):
        (tmp_path / name).write_text("<kml/>")
    with pytest.raises(CensusImportError, match=message):
        import_files(db, shapes=tmp_path / name, key="GEOID")


@pytest.mark.parametrize(
    ("part", "keep", "line"),
    [
        (
            ".shp",
            254,
            r"^s\.shp: its \.shp is cut short: its header declares 508 bytes, the file holds 254 ",
        ),
        (".shp", 60, r"^s\.shp: its \.shp is cut short: 60 bytes, less than its 100-byte header "),
        (
            ".shx",
            120,
            r"^s\.shp: its \.shx is cut short: its header declares 124 bytes, the file holds 120 ",
        ),
        (
            ".dbf",
            150,
            r"^s\.shp: its \.dbf is cut short: its header declares 253 bytes, the file holds 150 ",
        ),
    ],
)
def test_a_truncated_shapefile_is_refused_in_one_line_without_pyshps_warnings(
    db: Database, tmp_path: Path, recwarn: pytest.WarningsRecorder, part: str, keep: int, line: str
) -> None:
    """A copy or download cut off: said in tagwall's words, not as pyshp's warning and
    a struct error."""
    shapes = write_shapefile(tmp_path / "s")
    cut = shapes.with_suffix(part)
    cut.write_bytes(cut.read_bytes()[:keep])
    with pytest.raises(CensusImportError, match=line) as refused:
        import_files(db, shapes=shapes, key="GEOID")
    assert str(refused.value).endswith("(copy or download it again)")
    assert [str(w.message) for w in recwarn] == []
    assert store.list_datasets(db) == []


def test_a_shapefile_with_bytes_past_its_end_imports_without_pyshps_warnings(
    db: Database, tmp_path: Path, recwarn: pytest.WarningsRecorder
) -> None:
    shapes = write_shapefile(tmp_path / "s")
    shapes.write_bytes(shapes.read_bytes() + bytes(10))
    table = write_csv(tmp_path / "t.csv", TABLE)
    assert import_files(db, shapes=shapes, key="GEOID", tables=[table]).tracts == len(KEYS)
    assert [str(w.message) for w in recwarn] == []


def test_a_missing_key_column_names_the_columns(db: Database, tmp_path: Path) -> None:
    shapes = write_shapefile(tmp_path / "s")
    with pytest.raises(CensusImportError, match=r"s.shp has no column 'FIPS'; its columns: GEOID"):
        import_files(db, shapes=shapes, key="FIPS")
    table = write_csv(tmp_path / "t.csv", "FIPS,POP\n1,2\n")
    with pytest.raises(CensusImportError, match=r"t.csv has no column 'GEOID'"):
        import_files(db, shapes=shapes, key="GEOID", tables=[table])


def test_no_matching_keys_says_so(db: Database, tmp_path: Path) -> None:
    table = write_csv(tmp_path / "t.csv", "GEOID,POP\n6067000100,1\n")  # lost its zero
    with pytest.raises(CensusImportError, match=r"no shape matched.*06067000100.*6067000100"):
        import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    assert store.count(db) == 0


def test_columns_that_cannot_become_settings_are_refused_in_words(
    db: Database, tmp_path: Path
) -> None:
    long = "A" * 70  # an attribute's key has at most 64 characters
    table = write_csv(tmp_path / "t.csv", f"GEOID,{long}\n" + "".join(f"{k},1\n" for k in KEYS))
    refusal = r"cannot become settings \(key 'AAAA.*at most 64 characters"
    with pytest.raises(CensusImportError, match=refusal):
        import_files(db, shapes=write_shapefile(tmp_path / "s"), key="GEOID", tables=[table])
    assert store.count(db) == 0
