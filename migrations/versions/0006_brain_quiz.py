"""Brain atlas quiz: rounds, answers and who finished.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-23
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0006"
down_revision: str | None = "0005"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "brain_quiz_rounds",
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("number", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("started_by", sa.String(length=120), nullable=False),
        sa.PrimaryKeyConstraint("wall_id", "number", name=op.f("pk_brain_quiz_rounds")),
    )
    op.create_table(
        "brain_answers",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("round", sa.Integer(), nullable=False),
        sa.Column("visitor_id", sa.String(length=64), nullable=False),
        sa.Column("tag_set", sa.String(length=16), nullable=False),
        sa.Column("region_id", sa.String(length=64), nullable=False),
        sa.Column("answer", sa.String(length=200), nullable=False),
        sa.Column("correct", sa.Boolean(), nullable=False),
        sa.Column("answered_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_brain_answers")),
        sa.UniqueConstraint(
            "wall_id",
            "round",
            "visitor_id",
            "tag_set",
            "region_id",
            name=op.f("uq_brain_answers_wall_id"),
        ),
    )
    op.create_table(
        "brain_quiz_finishes",
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("round", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("visitor_id", sa.String(length=64), nullable=False),
        sa.Column("tag_set", sa.String(length=16), nullable=False),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint(
            "wall_id", "round", "visitor_id", "tag_set", name=op.f("pk_brain_quiz_finishes")
        ),
    )


def downgrade() -> None:
    op.drop_table("brain_quiz_finishes")
    op.drop_table("brain_answers")
    op.drop_table("brain_quiz_rounds")
