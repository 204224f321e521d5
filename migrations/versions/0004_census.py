"""Census map: imported data sets and their tracts.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-23
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0004"
down_revision: str | None = "0003"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "census_datasets",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("name", sa.String(length=64), nullable=False),
        sa.Column("settings", sa.JSON(), nullable=False),
        sa.Column("source", sa.String(length=500), nullable=False),
        sa.Column("tract_count", sa.Integer(), nullable=False),
        sa.Column("current", sa.Boolean(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_census_datasets")),
    )
    with op.batch_alter_table("census_datasets", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_census_datasets_name"), ["name"], unique=False)

    op.create_table(
        "census_tracts",
        sa.Column("dataset_id", sa.Integer(), nullable=False),
        sa.Column("geoid", sa.String(length=64), nullable=False),
        sa.Column("geometry", sa.JSON(), nullable=False),
        sa.Column("values", sa.JSON(), nullable=False),
        sa.ForeignKeyConstraint(
            ["dataset_id"],
            ["census_datasets.id"],
            name=op.f("fk_census_tracts_dataset_id_census_datasets"),
            ondelete="CASCADE",
        ),
        sa.PrimaryKeyConstraint("dataset_id", "geoid", name=op.f("pk_census_tracts")),
    )


def downgrade() -> None:
    op.drop_table("census_tracts")
    with op.batch_alter_table("census_datasets", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_census_datasets_name"))

    op.drop_table("census_datasets")
