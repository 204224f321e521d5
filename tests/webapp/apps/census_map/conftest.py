"""Census data for tests: the shipped Sacramento tracts, and small hand-made sets."""

from __future__ import annotations

import json
import tomllib
from functools import cache

import pytest
from shapely.geometry import box, shape

from webapp.apps.census_map.dataset import (
    Attribute,
    DataSet,
    DataSetSettings,
    Tract,
    county_of,
    tract_label,
)
from webapp.core.settings import CONTENT_DIR

SHIPPED = CONTENT_DIR / "census" / "sacramento-2000.geojson"


@cache
def sacramento() -> DataSet:
    """The shipped data set, read straight from its files (no database)."""
    features = json.loads(SHIPPED.read_text())["features"]
    settings = DataSetSettings.model_validate(
        tomllib.loads(SHIPPED.with_suffix(".toml").read_text())
    )
    tracts = tuple(
        Tract(
            geoid=f["properties"]["GEOID"],
            label=tract_label(f["properties"]["GEOID"]),
            county=county_of(f["properties"]["GEOID"]),
            shape=shape(f["geometry"]),
            values=settings.clean({k: v for k, v in f["properties"].items() if k != "GEOID"}),
        )
        for f in features
    )
    return DataSet(id=1, name="sacramento-2000", settings=settings, tracts=tracts)


def grid_dataset(columns: int = 4, rows: int = 3, size: float = 0.01) -> DataSet:
    """Square tracts in a grid near Sacramento, numbered 1..n, with two values each."""
    settings = DataSetSettings(
        title="Grid",
        headline=["POP"],
        attributes=[
            Attribute(key="POP", label="Population"),
            Attribute(key="INC", label="Income", kind="money", info_class=3),
        ],
    )
    tracts = []
    for index in range(columns * rows):
        i, j = index % columns, index // columns
        geoid = f"06067{index + 1:04d}00"
        tracts.append(
            Tract(
                geoid=geoid,
                label=tract_label(geoid),
                county=county_of(geoid),
                shape=box(
                    -121.5 + i * size,
                    38.5 - (j + 1) * size,
                    -121.5 + (i + 1) * size,
                    38.5 - j * size,
                ),
                values={"POP": 1000 + index, "INC": 50_000 + index},
            )
        )
    return DataSet(id=7, name="grid", settings=settings, tracts=tuple(tracts))


@pytest.fixture
def shipped() -> DataSet:
    return sacramento()
