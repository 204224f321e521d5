"""At most one current census data set (a partial unique index).

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-25
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0009"
down_revision: str | None = "0008"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    # Where two server processes both seeded the shipped data set, keep the newer current.
    op.execute(
        'UPDATE census_datasets SET "current" = false WHERE "current" AND id <> '
        '(SELECT max(id) FROM census_datasets WHERE "current")'
    )
    op.create_index(
        "ix_census_datasets_one_current",
        "census_datasets",
        ["current"],
        unique=True,
        postgresql_where=sa.text('"current"'),
        sqlite_where=sa.text('"current"'),
    )


def downgrade() -> None:
    op.drop_index("ix_census_datasets_one_current", table_name="census_datasets")
