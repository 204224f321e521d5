"""Brain quiz rounds that keep the key secret: a random pin order per round, when
students see the names, closing; the wall's choice about audience group switches.

Rounds from before this revision numbered pins in the content's order, which anyone
can read in the repository: they are closed, so the next round starts afresh.

Revision ID: 0007
Revises: 0006
Create Date: 2026-12-01
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0007"
down_revision: str | None = "0006"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("brain_quiz_rounds", schema=None) as batch_op:
        batch_op.add_column(sa.Column("orders", sa.JSON(), nullable=False, server_default="{}"))
        batch_op.add_column(
            sa.Column("reveal", sa.String(length=16), nullable=False, server_default="close")
        )
        batch_op.add_column(sa.Column("closed_at", sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column("closed_by", sa.String(length=120), nullable=True))
        batch_op.add_column(sa.Column("last_answer_at", sa.DateTime(timezone=True), nullable=True))
    rounds = sa.table(
        "brain_quiz_rounds",
        sa.column("started_at", sa.DateTime(timezone=True)),
        sa.column("closed_at", sa.DateTime(timezone=True)),
        sa.column("closed_by", sa.String(length=120)),
    )
    op.execute(
        rounds.update()
        .where(rounds.c.closed_at.is_(None))
        .values(closed_at=rounds.c.started_at, closed_by="upgrade")
    )
    with op.batch_alter_table("brain_quiz_rounds", schema=None) as batch_op:
        batch_op.alter_column("orders", server_default=None)
        batch_op.alter_column("reveal", server_default=None)
    op.create_table(
        "brain_walls",
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("audience_switches", sa.Boolean(), nullable=False),
        sa.Column("audience_switched_at", sa.DateTime(timezone=True), nullable=True),
        sa.PrimaryKeyConstraint("wall_id", name=op.f("pk_brain_walls")),
    )


def downgrade() -> None:
    op.drop_table("brain_walls")
    with op.batch_alter_table("brain_quiz_rounds", schema=None) as batch_op:
        batch_op.drop_column("last_answer_at")
        batch_op.drop_column("closed_by")
        batch_op.drop_column("closed_at")
        batch_op.drop_column("reveal")
        batch_op.drop_column("orders")
