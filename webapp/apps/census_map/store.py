"""Census data sets in the database: saved whole or not at all, loaded once per id.

A data set never changes once saved (an import makes a new one), so a loaded
:class:`DataSet` is cached by id for as long as the app runs.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from shapely.geometry import shape
from sqlalchemy import func, select, update

from webapp.apps.census_map.dataset import (
    DataSet,
    DataSetSettings,
    Tract,
    Value,
    county_of,
    tract_label,
)
from webapp.core.settings import CONTENT_DIR, Settings
from webapp.database.connection import Database
from webapp.database.models import CensusDataSetRecord, CensusTractRecord

FOLDER_NAME = "census"
"""The app's subfolder of the content folder (``TAGWALL_CONTENT_DIR``)."""
SHIPPED_NAME = "sacramento-2000.geojson"
SHIPPED = CONTENT_DIR / FOLDER_NAME / SHIPPED_NAME
"""The shipped data set as the checkout holds it (tests, benchmarks); a server starts
from :func:`first_dataset`."""
SHIPPED_KEY = "GEOID"
KEPT_LOADED = 4


def first_dataset(settings: Settings) -> Path:
    """The data set a database without one is seeded from: ``census/`` of the content
    folder (its settings beside it, as ``.toml``), or the shipped one when that folder
    has no ``census/``."""
    return settings.content_folder(FOLDER_NAME) / SHIPPED_NAME


@dataclass(frozen=True)
class TractRow:
    """A tract as an import hands it over: key, GeoJSON geometry (lon/lat), values."""

    geoid: str
    geometry: dict[str, Any]
    values: dict[str, Value]


@dataclass(frozen=True)
class DataSetInfo:
    id: int
    name: str
    title: str
    tract_count: int
    current: bool
    created_at: datetime
    source: str


def save(
    db: Database, name: str, settings: DataSetSettings, rows: Sequence[TractRow], source: str
) -> int:
    """Store a data set and make it current, in one transaction: all of it or nothing."""
    with db.session() as session:
        record = CensusDataSetRecord(
            name=name,
            settings=settings.model_dump(mode="json"),
            source=source[:500],
            tract_count=len(rows),
            current=False,
        )
        session.add(record)
        session.flush()
        session.add_all(
            CensusTractRecord(
                dataset_id=record.id, geoid=row.geoid, geometry=row.geometry, values=row.values
            )
            for row in rows
        )
        session.flush()
        _make_current(session, record.id)
        return record.id


def make_current(db: Database, dataset_id: int) -> None:
    """Make ``dataset_id`` the data set the census map shows (KeyError: no such one)."""
    with db.session() as session:
        if session.get(CensusDataSetRecord, dataset_id) is None:
            raise KeyError(dataset_id)
        _make_current(session, dataset_id)


def _make_current(session: Any, dataset_id: int) -> None:
    """Two steps: the database allows one current data set at any moment of an update."""
    for values, rows in (
        ({"current": False}, CensusDataSetRecord.current.is_(True)),
        ({"current": True}, CensusDataSetRecord.id == dataset_id),
    ):
        session.execute(
            update(CensusDataSetRecord)
            .where(rows)
            .values(**values)
            .execution_options(synchronize_session=False)
        )


def current_id(db: Database) -> int | None:
    with db.session() as session:
        return session.scalar(
            select(CensusDataSetRecord.id)
            .where(CensusDataSetRecord.current.is_(True))
            .order_by(CensusDataSetRecord.id.desc())
            .limit(1)
        )


def list_datasets(db: Database) -> list[DataSetInfo]:
    with db.session() as session:
        records = session.scalars(
            select(CensusDataSetRecord).order_by(CensusDataSetRecord.id.desc())
        ).all()
        return [
            DataSetInfo(
                id=r.id,
                name=r.name,
                title=str(r.settings.get("title", r.name)),
                tract_count=r.tract_count,
                current=r.current,
                created_at=r.created_at,
                source=r.source,
            )
            for r in records
        ]


def count(db: Database) -> int:
    with db.session() as session:
        return session.scalar(select(func.count()).select_from(CensusDataSetRecord)) or 0


def load(db: Database, dataset_id: int) -> DataSet | None:
    with db.session() as session:
        record = session.get(CensusDataSetRecord, dataset_id)
        if record is None:
            return None
        rows = session.scalars(
            select(CensusTractRecord)
            .where(CensusTractRecord.dataset_id == dataset_id)
            .order_by(CensusTractRecord.geoid)
        ).all()
        settings = DataSetSettings.model_validate(record.settings)
        tracts = tuple(
            Tract(
                geoid=row.geoid,
                label=tract_label(row.geoid),
                county=county_of(row.geoid),
                shape=shape(row.geometry),
                values=settings.clean(row.values),
                name=settings.names.get(row.geoid, ""),
            )
            for row in rows
        )
        return DataSet(id=record.id, name=record.name, settings=settings, tracts=tracts)


class DataSets:
    """Loaded data sets by id, the few most recently used (they are immutable)."""

    def __init__(self) -> None:
        self._loaded: OrderedDict[int, DataSet] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, db: Database, dataset_id: int) -> DataSet | None:
        with self._lock:
            if dataset_id in self._loaded:
                self._loaded.move_to_end(dataset_id)
                return self._loaded[dataset_id]
        dataset = load(db, dataset_id)
        if dataset is not None:
            with self._lock:
                self._loaded[dataset_id] = dataset
                while len(self._loaded) > KEPT_LOADED:
                    self._loaded.popitem(last=False)
        return dataset

    def current(self, db: Database) -> DataSet | None:
        dataset_id = current_id(db)
        return self.get(db, dataset_id) if dataset_id is not None else None
