"""An app's own tables: its revisions run with the core's, in a history of their own,
and go down before the core's."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
from sqlalchemy import inspect

from webapp.database.connection import make_engine
from webapp.database.migrate import downgrade, downgrade_app, upgrade, version_table

REVISION = '''
"""The poll's questions."""

import sqlalchemy as sa
from alembic import op

revision = "poll_0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "poll_questions",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("text", sa.String(200), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("poll_questions")
'''


@pytest.fixture
def poll_migrations(tmp_path: Path) -> Path:
    folder = tmp_path / "poll_migrations"
    folder.mkdir()
    (folder / "poll_0001_questions.py").write_text(textwrap.dedent(REVISION))
    return folder


def tables(url: str) -> set[str]:
    engine = make_engine(url)
    try:
        return set(inspect(engine).get_table_names())
    finally:
        engine.dispose()


def test_an_apps_revisions_run_with_the_cores_in_a_history_of_their_own(
    database_url: str, poll_migrations: Path
) -> None:
    upgrade(database_url, apps={"poll": poll_migrations})
    found = tables(database_url)
    assert {"poll_questions", version_table("poll"), "alembic_version", "wall_states"} <= found
    upgrade(database_url, apps={"poll": poll_migrations})  # idempotent
    # uninstalled: the core's upgrades go on without knowing the app's revisions
    upgrade(database_url)
    assert "poll_questions" in tables(database_url)


def test_an_app_goes_down_alone_or_before_the_core(
    database_url: str, poll_migrations: Path
) -> None:
    apps = {"poll": poll_migrations}
    upgrade(database_url, apps=apps)
    downgrade_app(database_url, "poll", poll_migrations, "base")
    assert "poll_questions" not in tables(database_url)
    assert "wall_states" in tables(database_url)
    upgrade(database_url, apps=apps)
    downgrade(database_url, "base", apps)
    assert tables(database_url) <= {"alembic_version", version_table("poll")}
