"""Quiz questions for any app: an answer may be judged neither right nor wrong (a poll's
``correct`` is NULL), and may be final as given (``final``: answered once, never changed).

Revision ID: 0014
Revises: 0013
Create Date: 2026-12-02
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0014"
down_revision: str | None = "0013"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("quiz_answers", schema=None) as batch_op:
        batch_op.alter_column("correct", existing_type=sa.Boolean(), nullable=True)
        batch_op.add_column(
            sa.Column("final", sa.Boolean(), nullable=False, server_default=sa.false())
        )
    with op.batch_alter_table("quiz_answers", schema=None) as batch_op:
        batch_op.alter_column("final", server_default=None)


def downgrade() -> None:
    """Back to judged answers only: a poll's answers (not judged) count as wrong."""
    answers = sa.table("quiz_answers", sa.column("correct", sa.Boolean()))
    op.execute(answers.update().where(answers.c.correct.is_(None)).values(correct=False))
    with op.batch_alter_table("quiz_answers", schema=None) as batch_op:
        batch_op.drop_column("final")
        batch_op.alter_column("correct", existing_type=sa.Boolean(), nullable=False)
