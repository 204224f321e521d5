"""Migrations reach head on an empty database and match the models exactly."""

import json

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect, text

from webapp.database.connection import Base, make_engine
from webapp.database.migrate import alembic_config, upgrade


def test_upgrade_head_has_no_drift(database_url: str) -> None:
    upgrade(database_url)
    engine = make_engine(database_url)
    with engine.connect() as connection:
        diff = compare_metadata(MigrationContext.configure(connection), Base.metadata)
    engine.dispose()
    assert diff == [], f"models and migrations differ; write a migration: {diff}"


def test_upgrade_is_idempotent(database_url: str) -> None:
    upgrade(database_url)
    upgrade(database_url)
    engine = make_engine(database_url)
    assert {"wall_states", "wall_events", "alembic_version"} <= set(
        inspect(engine).get_table_names()
    )
    engine.dispose()


def test_rounds_from_before_0007_are_closed_their_key_was_public(database_url: str) -> None:
    """Before 0007 pins were numbered in the content's order: such a round must not go
    on counting answers after the upgrade."""
    upgrade(database_url, "0006")
    engine = make_engine(database_url)
    with engine.begin() as connection:
        connection.execute(
            text(
                "INSERT INTO brain_quiz_rounds (wall_id, number, started_at, started_by)"
                " VALUES ('demo', 1, CURRENT_TIMESTAMP, 'ann')"
            )
        )
    upgrade(database_url, "0007")
    with engine.connect() as connection:
        row = connection.execute(
            text("SELECT closed_at, reveal, orders FROM brain_quiz_rounds")
        ).one()
    engine.dispose()
    assert row.closed_at is not None and row.reveal == "close"


def test_a_sacramento_data_set_seeded_before_0010_gets_readable_labels(database_url: str) -> None:
    """Seeded once, the shipped data set kept the labels of its day: the upgrade gives
    the occupation columns words, and leaves every other label as it was."""
    upgrade(database_url, "0009")
    engine = make_engine(database_url)
    settings = {
        "title": "Sacramento MSA census tracts, 2000",
        "headline": ["TOT_POP"],
        "attributes": [
            {"key": "TOT_POP", "label": "People here"},  # an instructor's own label
            {"key": "OCC_MAN", "label": "Employed civilians: OCC_MAN occupation group"},
        ],
    }
    with engine.begin() as connection:
        connection.execute(
            text(
                'INSERT INTO census_datasets (name, settings, source, tract_count, "current",'
                " created_at) VALUES ('sacramento-2000', :settings, 'sacramento-2000.geojson',"
                " 403, true, CURRENT_TIMESTAMP)"
            ),
            {"settings": json.dumps(settings)},
        )
    upgrade(database_url)
    with engine.connect() as connection:
        stored = connection.execute(text("SELECT settings FROM census_datasets")).scalar_one()
    engine.dispose()
    stored = stored if isinstance(stored, dict) else json.loads(stored)
    assert [a["label"] for a in stored["attributes"]] == [
        "People here",
        "Employed civilians in production occupations",
    ]
    assert stored["title"] == settings["title"]


def _rows(database_url: str, query: str) -> list[tuple[object, ...]]:
    engine = make_engine(database_url)
    with engine.connect() as connection:
        rows = [tuple(row) for row in connection.execute(text(query))]
    engine.dispose()
    return [
        tuple(json.loads(v) if isinstance(v, str) and v.startswith("{") else v for v in row)
        for row in rows
    ]


def test_0011_moves_the_apps_fields_into_their_slots_and_back(database_url: str) -> None:
    """States and the event history alike: a tile catching up across the upgrade reads
    the census map's colouring and the brain's round in their apps' slots."""
    upgrade(database_url, "0010")
    theme = {"attribute": "TOT_POP", "scheme": "blues", "method": "quantile", "classes": 5}
    engine = make_engine(database_url)
    with engine.begin() as connection:
        for wall_id, state in (
            ("census", {"app": "census", "dataset": 3, "theme": theme, "quiz_round": None}),
            ("brain", {"app": "brain", "quiz_round": 7, "mode": "quiz"}),
            ("fresh", {"mode": "default"}),
        ):
            connection.execute(
                text(
                    "INSERT INTO wall_states (wall_id, version, state, updated_at)"
                    " VALUES (:wall, 2, :state, CURRENT_TIMESTAMP)"
                ),
                {"wall": wall_id, "state": json.dumps(state)},
            )
        for version, changes in ((1, {"dataset": 3, "view": {"zoom": 2}}), (2, {"theme": theme})):
            connection.execute(
                text(
                    "INSERT INTO wall_events (wall_id, version, changes, heavy, created_at)"
                    " VALUES ('census', :version, :changes, true, CURRENT_TIMESTAMP)"
                ),
                {"version": version, "changes": json.dumps(changes)},
            )
    engine.dispose()
    upgrade(database_url)
    states = dict(_rows(database_url, "SELECT wall_id, state FROM wall_states"))
    assert states["census"] == {
        "app": "census",
        "apps": {"census": {"dataset": 3, "theme": theme, "version": 1}},
    }
    assert states["brain"] == {
        "app": "brain",
        "mode": "quiz",
        "apps": {"brain": {"quiz_round": 7, "version": 1}},
    }
    assert states["fresh"] == {"app": "pattern", "mode": "default", "apps": {}}
    events = _rows(database_url, "SELECT version, changes FROM wall_events ORDER BY version")
    assert events == [
        (1, {"view": {"zoom": 2}, "apps": {"census": {"dataset": 3}}}),
        (2, {"apps": {"census": {"theme": theme}}}),
    ]
    command.downgrade(alembic_config(database_url), "0010")
    states = dict(_rows(database_url, "SELECT wall_id, state FROM wall_states"))
    assert states["census"] == {"app": "census", "dataset": 3, "theme": theme}
    assert states["brain"] == {"app": "brain", "mode": "quiz", "quiz_round": 7}
    events = _rows(database_url, "SELECT version, changes FROM wall_events ORDER BY version")
    assert events == [(1, {"view": {"zoom": 2}, "dataset": 3}), (2, {"theme": theme})]


def test_0013_moves_the_brains_quiz_into_the_shared_engine_and_back(database_url: str) -> None:
    """Rounds, answers and finishes alike, as the brain's (app ``brain``)."""
    upgrade(database_url, "0012")
    engine = make_engine(database_url)
    with engine.begin() as connection:
        for statement in (
            "INSERT INTO brain_quiz_rounds (wall_id, number, started_at, started_by, orders,"
            " reveal) VALUES ('demo', 4, CURRENT_TIMESTAMP, 'ann', '{\"k5\": [\"a\"]}',"
            " 'finish')",
            "INSERT INTO brain_answers (wall_id, round, visitor_id, tag_set, region_id, answer,"
            " correct, answered_at) VALUES ('demo', 4, 'v1', 'k5', 'a', 'Alpha', true,"
            " CURRENT_TIMESTAMP)",
            "INSERT INTO brain_quiz_finishes (wall_id, round, visitor_id, tag_set, finished_at)"
            " VALUES ('demo', 4, 'v1', 'k5', CURRENT_TIMESTAMP)",
        ):
            connection.execute(text(statement))
    engine.dispose()
    upgrade(database_url)
    assert _rows(database_url, "SELECT app, wall_id, number, reveal FROM quiz_rounds") == [
        ("brain", "demo", 4, "finish")
    ]
    assert _rows(
        database_url, "SELECT app, round, visitor_id, set_name, item_id, answer FROM quiz_answers"
    ) == [("brain", 4, "v1", "k5", "a", "Alpha")]
    assert _rows(database_url, "SELECT app, set_name FROM quiz_finishes") == [("brain", "k5")]
    command.downgrade(alembic_config(database_url), "0012")
    assert _rows(database_url, "SELECT wall_id, number, reveal FROM brain_quiz_rounds") == [
        ("demo", 4, "finish")
    ]
    assert _rows(database_url, "SELECT tag_set, region_id, answer FROM brain_answers") == [
        ("k5", "a", "Alpha")
    ]
    assert _rows(database_url, "SELECT tag_set FROM brain_quiz_finishes") == [("k5",)]


def test_0014_keeps_answers_judged_and_changeable_and_back(database_url: str) -> None:
    """Answers from before stay as judged and may still change (not final); going back,
    a poll's unjudged answer counts as wrong (the column held no NULL before)."""
    upgrade(database_url, "0013")
    engine = make_engine(database_url)
    with engine.begin() as connection:
        connection.execute(
            text(
                "INSERT INTO quiz_answers (app, wall_id, round, visitor_id, set_name, item_id,"
                " answer, correct, answered_at) VALUES ('brain', 'demo', 1, 'v1', 'k5', 'a',"
                " 'Alpha', true, CURRENT_TIMESTAMP)"
            )
        )
    engine.dispose()
    upgrade(database_url)
    assert _rows(database_url, "SELECT answer, correct, final FROM quiz_answers") == [
        ("Alpha", True, False)
    ]
    engine = make_engine(database_url)
    with engine.begin() as connection:
        connection.execute(
            text(
                "INSERT INTO quiz_answers (app, wall_id, round, visitor_id, set_name, item_id,"
                " answer, correct, final, answered_at) VALUES ('poll', 'demo', 1, 'v1', 'p',"
                " 'q', 'Yes', NULL, true, CURRENT_TIMESTAMP)"
            )
        )
    engine.dispose()
    command.downgrade(alembic_config(database_url), "0013")
    assert _rows(database_url, "SELECT answer, correct FROM quiz_answers ORDER BY id") == [
        ("Alpha", True),
        ("Yes", False),
    ]
