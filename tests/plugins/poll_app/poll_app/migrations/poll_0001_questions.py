"""The poll's questions: one row per poll (a round of the app's quiz), with its text and
choices, kept after the poll closes for its CSV.

Revision ID: poll_0001
Revises: (none: the first of the poll's own history)
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "poll_0001"
down_revision: str | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "poll_questions",
        sa.Column("wall_id", sa.String(64), nullable=False),
        sa.Column("round", sa.Integer, nullable=False),
        sa.Column("text", sa.String(200), nullable=False),
        sa.Column("choices", sa.JSON, nullable=False),
        sa.PrimaryKeyConstraint("wall_id", "round", name="pk_poll_questions"),
    )


def downgrade() -> None:
    op.drop_table("poll_questions")
