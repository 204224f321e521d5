"""Census Bureau tables from data.census.gov: labels from the metadata, estimates with
their margins of error, the Bureau's symbols, and every way a download can be wrong
refused in one line with nothing stored."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import pytest

from tests.webapp.apps.census_map.test_importer import (
    assert_only,
    first_data_set,
    polygon,
    square,
    write_csv,
    write_geojson,
    write_shapefile,
)
from webapp.apps.census_map import acs, store
from webapp.apps.census_map.dataset import OPEN_ABOVE, DataSet, fact
from webapp.apps.census_map.importer import CensusImportError, import_files
from webapp.database.connection import Database

TABLES = Path(__file__).parent / "acs_tables"
INCOME, VALUE = "ACSDT5Y2022.B19013", "ACSDT5Y2022.B25077"
LABEL = "Median household income in the past 12 months (in 2022 inflation-adjusted dollars)"


def downloaded(folder: Path, *tables: str) -> list[Path]:
    """The tables' -Data.csv files, each with its metadata beside it, as unzipped."""
    for table in tables:
        for part in ("-Data.csv", "-Column-Metadata.csv"):
            shutil.copy(TABLES / f"{table}{part}", folder / f"{table}{part}")
    return [folder / f"{table}-Data.csv" for table in tables]


def zipped(folder: Path, table: str) -> Path:
    """The zip data.census.gov hands out: data, metadata and notes."""
    path = folder / f"{table}_2024-05-01T120000.zip"
    with zipfile.ZipFile(path, "w") as archive:
        for part in ("-Data.csv", "-Column-Metadata.csv"):
            archive.write(TABLES / f"{table}{part}", f"{table}{part}")
        archive.writestr(f"{table}-Table-Notes.txt", "Table notes\r\n")
    return path


def imported(db: Database, tmp_path: Path, tables: list[Path]) -> DataSet:
    report = import_files(
        db, shapes=write_shapefile(tmp_path / "tracts"), key="GEOID", tables=tables
    )
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    return dataset


def test_an_acs_table_imports_with_labels_margins_and_symbols(db: Database, tmp_path: Path) -> None:
    report = import_files(
        db,
        shapes=write_shapefile(tmp_path / "tracts"),
        key="GEOID",
        tables=downloaded(tmp_path, INCOME, VALUE),
    )
    assert report.attributes == ("B19013_001E", "B25077_001E")
    assert report.margins == ("B19013_001M", "B25077_001M")
    assert report.ignored_columns == ("NAME",)  # the table's; the shapes' names the tracts
    assert "tract names: NAME of the shapes (3 of 3 tracts named)" in report.lines()
    assert not report.unmatched_rows and not report.unmatched_shapes  # GEO_ID joins GEOID
    assert "margins of error: B19013_001M, B25077_001M" in report.lines()
    dataset = store.load(db, report.dataset_id)
    assert dataset is not None
    settings = dataset.settings
    assert settings.title == "ACS 5-year estimates 2018-2022: B19013, B25077"
    assert "data.census.gov: ACSDT5Y2022.B19013, ACSDT5Y2022.B25077" in settings.source
    income, value = settings.attributes
    assert (income.label, income.kind, income.margin) == (LABEL, "money", "B19013_001M")
    assert (value.label, value.kind, value.margin) == (
        "Median value (dollars)",
        "money",
        "B25077_001M",
    )
    assert settings.headline == ["B19013_001E", "B25077_001E"]
    assert settings.counties == {"06067": "Sacramento County"}  # from NAME
    one, two, three = dataset.tracts
    # the shapes' text NAME ("Census Tract 1"; TIGER/Line's is the number "1", no name)
    assert dataset.tract_title(one) == "Census Tract 1, Sacramento County"
    assert one.values == {
        "B19013_001E": 52941,
        "B19013_001M": 6123,
        "B25077_001E": 412300,
        "B25077_001M": 35120,
    }
    # "250,000+" with "***", and the API's 2000001 annotated "2,000,000+": bounds
    assert two.values == {
        "B19013_001E": 250000,
        "B19013_001M": OPEN_ABOVE,
        "B25077_001E": 2000000,
        "B25077_001M": OPEN_ABOVE,
    }
    assert set(three.values.values()) == {None}  # "-" and "**"; -666666666 and -222222222


def test_the_phone_reads_margins_by_information_class(db: Database, tmp_path: Path) -> None:
    dataset = imported(db, tmp_path, downloaded(tmp_path, INCOME, VALUE))
    income, value = dataset.settings.attributes
    one, two, three = dataset.tracts
    child = fact(income, one.values, 1)
    assert (child.value, child.margin, child.share, child.uncertain) == (
        "$52,941",
        None,
        None,
        True,
    )
    middle = fact(income, one.values, 2)
    assert (middle.margin, middle.share, middle.uncertain) == ("± $6,123", None, True)
    expert = fact(income, one.values, 5)
    assert (expert.margin, expert.share) == ("± $6,123", "12%")
    assert expert.text() == "$52,941 ± $6,123 (12%) (uncertain)"
    close = fact(value, one.values, 5)  # 35,120 is 8.5 % of 412,300
    assert (close.margin, close.uncertain) == ("± $35,120", False)
    bound = fact(income, two.values, 5)
    assert (bound.value, bound.margin, bound.uncertain) == ("$250,000 or more", None, False)
    assert fact(value, two.values, 5).value == "$2,000,000 or more"
    missing = fact(income, three.values, 5)
    assert (missing.value, missing.margin, missing.uncertain) == ("not available", None, False)


def test_the_downloaded_zip_imports_as_its_files_do(db: Database, tmp_path: Path) -> None:
    dataset = imported(db, tmp_path, [zipped(tmp_path, INCOME), zipped(tmp_path, VALUE)])
    assert [a.label for a in dataset.settings.attributes] == [LABEL, "Median value (dollars)"]
    assert dataset.tracts[0].values["B19013_001M"] == 6123


def test_tracts_keyed_by_the_whole_geo_id_join_as_well(db: Database, tmp_path: Path) -> None:
    """TIGER/Line's GEOIDFQ holds the whole GEO_ID (1400000US06067000100)."""
    shapes = write_geojson(
        tmp_path / "fq.geojson",
        [(f"1400000US06067000{n}00", polygon(square(n)), {}) for n in (1, 2, 3)],
    )
    report = import_files(db, shapes=shapes, key="GEOID", tables=downloaded(tmp_path, INCOME))
    assert report.tracts == 3 and not report.unmatched_rows


def test_an_acs_table_joins_a_csv_of_ones_own(db: Database, tmp_path: Path) -> None:
    own = write_csv(
        tmp_path / "parks.csv", "GEOID,PARKS\n06067000100,2\n06067000200,0\n06067000300,1\n"
    )
    dataset = imported(db, tmp_path, [*downloaded(tmp_path, INCOME), own])
    assert [a.key for a in dataset.settings.attributes] == ["B19013_001E", "PARKS"]
    assert dataset.settings.attributes[1].label == "PARKS"  # no metadata: its name
    assert dataset.tracts[1].values["PARKS"] == 0


def test_labels_stay_readable_and_tell_alike_columns_apart() -> None:
    table = acs.CensusTable(
        name="ACSDT5Y2022.B01001-Data.csv",
        product="ACSDT5Y2022",
        table="B01001",
        estimates=["B01001_001E", "B01001_002E", "B01001_003E", "B01001_027E", "DP05_0002PE"],
        margins={},
        labels={
            "B01001_001E": "Estimate!!Total:",
            "B01001_002E": "Estimate!!Total:!!Male:",
            "B01001_003E": "Estimate!!Total:!!Male:!!Under 5 years",
            "B01001_027E": "Estimate!!Total:!!Female:!!Under 5 years",
            "DP05_0002PE": 'Percent!!SEX AND AGE!!Total population!!Male "alone"',
        },
        records={},
        left_out=[],
        counties={},
    )
    described = acs.describe([table])
    assert [a.label for a in described.values()] == [
        "Total (B01001)",
        "Male",
        "Male: Under 5 years",
        "Female: Under 5 years",
        "Male alone",
    ]
    assert [a.kind for a in described.values()] == ["count"] * 4 + ["percent"]


def test_a_download_from_before_2023_reads_too(db: Database, tmp_path: Path) -> None:
    """``..._data_with_overlays_<time>.csv`` with ``..._metadata_<time>.csv`` (no
    header row) and "id" over the labels."""
    data = tmp_path / "ACSDT5Y2019.B19013_data_with_overlays_2020-11-10T165406.csv"
    data.write_text(
        '"GEO_ID","NAME","B19013_001E","B19013_001M"\n'
        '"id","Geographic Area Name","Estimate!!Median household income","Margin of Error!!'
        'Median household income"\n'
        + "".join(f'"1400000US06067000{n}00","Tract {n}","5{n}000","4{n}00"\n' for n in (1, 2, 3))
    )
    (tmp_path / "ACSDT5Y2019.B19013_metadata_2020-11-10T165406.csv").write_text(
        '"GEO_ID","id"\n"NAME","Geographic Area Name"\n'
        '"B19013_001E","Estimate!!Median household income"\n'
        '"B19013_001M","Margin of Error!!Median household income"\n'
    )
    dataset = imported(db, tmp_path, [data])
    assert dataset.settings.attributes[0].label == "Median household income"
    assert dataset.settings.title == "ACS 5-year estimates 2015-2019: B19013"
    assert dataset.tracts[2].values == {"B19013_001E": 53000, "B19013_001M": 4300}


def refused(db: Database, tmp_path: Path, tables: list[Path]) -> str:
    """The import's one-line refusal; the first data set stays the only one, whole."""
    first = first_data_set(db, tmp_path)
    with pytest.raises(CensusImportError) as error:
        import_files(db, shapes=write_shapefile(tmp_path / "tracts"), key="GEOID", tables=tables)
    assert_only(db, first)
    message = str(error.value)
    assert "\n" not in message
    return message


def test_a_table_without_its_metadata_is_refused(db: Database, tmp_path: Path) -> None:
    [data] = downloaded(tmp_path, INCOME)
    (tmp_path / f"{INCOME}-Column-Metadata.csv").unlink()
    message = refused(db, tmp_path, [data])
    assert message.startswith(f"{INCOME}-Data.csv is a data.census.gov table, but its column")
    assert f"put {INCOME}-Column-Metadata.csv (from the same download) beside it" in message


def test_a_zip_without_the_metadata_is_refused(db: Database, tmp_path: Path) -> None:
    path = tmp_path / "download.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.write(TABLES / f"{INCOME}-Data.csv", f"{INCOME}-Data.csv")
    message = refused(db, tmp_path, [path])
    assert message == (
        f"download.zip: {INCOME}-Data.csv is there but its column metadata "
        f"{INCOME}-Column-Metadata.csv is not"
    )


def test_metadata_of_another_table_is_refused(db: Database, tmp_path: Path) -> None:
    [data] = downloaded(tmp_path, INCOME)
    shutil.copy(TABLES / f"{VALUE}-Column-Metadata.csv", tmp_path / f"{INCOME}-Column-Metadata.csv")
    message = refused(db, tmp_path, [data])
    assert message == (
        f"{INCOME}-Column-Metadata.csv does not describe B19013_001E, B19013_001M of "
        f"{INCOME}-Data.csv: the metadata must come from the same download as the data"
    )


def test_metadata_describing_columns_the_data_lack_is_refused(db: Database, tmp_path: Path) -> None:
    [data] = downloaded(tmp_path, INCOME)
    metadata = tmp_path / f"{INCOME}-Column-Metadata.csv"
    metadata.write_bytes(metadata.read_bytes() + b'"B19013_002E","Estimate!!Other"\r\n')
    assert "describes B19013_002E, which" in refused(db, tmp_path, [data])


def test_labels_that_disagree_with_the_metadata_are_refused(db: Database, tmp_path: Path) -> None:
    [data] = downloaded(tmp_path, INCOME)
    data.write_text(data.read_text(encoding="utf-8").replace("2022 inflation", "2021 inflation"))
    message = refused(db, tmp_path, [data])
    assert message.startswith(f"{INCOME}-Data.csv and {INCOME}-Column-Metadata.csv label ")


@pytest.mark.parametrize(
    "cell,column", [("abc", "B19013_001E"), ("12 345", "B19013_001E"), ("+-", "B19013_001M")]
)
def test_a_cell_that_is_neither_a_number_nor_a_symbol_is_refused(
    db: Database, tmp_path: Path, cell: str, column: str
) -> None:
    [data] = downloaded(tmp_path, INCOME)
    new = f'"{cell}","6123"' if column.endswith("E") else f'"52941","{cell}"'
    data.write_text(data.read_text(encoding="utf-8").replace('"52941","6123"', new))
    assert refused(db, tmp_path, [data]) == (
        f"{INCOME}-Data.csv: {column} of 1400000US06067000100 reads {cell!r}, neither a number "
        f"nor one of the Census Bureau's symbols ({acs.SYMBOLS})"
    )


def test_the_same_table_twice_is_refused(db: Database, tmp_path: Path) -> None:
    [data] = downloaded(tmp_path, INCOME)
    message = refused(db, tmp_path, [data, zipped(tmp_path, INCOME)])
    assert message.startswith("column B19013_001E is in both")


def test_settings_naming_a_margin_the_data_lack_are_refused(db: Database, tmp_path: Path) -> None:
    settings = tmp_path / "income.toml"
    settings.write_text(
        'title = "Income"\nheadline = ["B19013_001E"]\n'
        '[[attributes]]\nkey = "B19013_001E"\nlabel = "Income"\nmargin = "B19013_009M"\n'
    )
    first = first_data_set(db, tmp_path)
    with pytest.raises(
        CensusImportError, match=r"names margins of error the data lack: B19013_009M"
    ):
        import_files(
            db,
            shapes=write_shapefile(tmp_path / "tracts"),
            key="GEOID",
            tables=downloaded(tmp_path, INCOME),
            settings=settings,
        )
    assert_only(db, first)


def test_a_2020_census_table_reads_the_same_way_without_margins(
    db: Database, tmp_path: Path
) -> None:
    """The decennial census's downloads share the layout: counts (N) and annotations."""
    rows = [
        ["GEO_ID", "NAME", "P1_001N", "P1_001NA"],
        ["Geography", "Geographic Area Name", " !!Total", "Annotation of  !!Total"],
        *[[f"1400000US06067000{n}00", f"Census Tract {n}", f"{n}012", "null"] for n in (1, 2, 3)],
    ]
    data = tmp_path / "DECENNIALDHC2020.P1-Data.csv"
    data.write_text("".join(",".join(f'"{c}"' for c in row) + ",\r\n" for row in rows))
    (tmp_path / "DECENNIALDHC2020.P1-Column-Metadata.csv").write_text(
        '"Column Name","Label"\r\n'
        + "".join(f'"{code}","{label}"\r\n' for code, label in zip(*rows[:2], strict=True))
    )
    dataset = imported(db, tmp_path, [data])
    [total] = dataset.settings.attributes
    assert (total.key, total.label, total.kind, total.margin) == (
        "P1_001N",
        "Total (P1)",
        "count",
        None,
    )
    assert [t.values for t in dataset.tracts] == [{"P1_001N": n * 1000 + 12} for n in (1, 2, 3)]
