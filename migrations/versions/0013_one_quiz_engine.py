"""One quiz engine: the brain atlas's rounds, answers and finishes become every app's
(``quiz_*`` tables with an ``app`` column); the brain's rows move over as app ``brain``.

Revision ID: 0013
Revises: 0012
Create Date: 2026-11-27
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0013"
down_revision: str | None = "0012"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

ROUND_COLUMNS = (
    "wall_id, number, started_at, started_by, orders, reveal, closed_at, closed_by, last_answer_at"
)


def upgrade() -> None:
    op.create_table(
        "quiz_rounds",
        sa.Column("app", sa.String(length=64), nullable=False),
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("number", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("started_by", sa.String(length=120), nullable=False),
        sa.Column("orders", sa.JSON(), nullable=False),
        sa.Column("reveal", sa.String(length=16), nullable=False),
        sa.Column("closed_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("closed_by", sa.String(length=120), nullable=True),
        sa.Column("last_answer_at", sa.DateTime(timezone=True), nullable=True),
        sa.PrimaryKeyConstraint("app", "wall_id", "number", name=op.f("pk_quiz_rounds")),
    )
    op.create_table(
        "quiz_answers",
        sa.Column("id", sa.Integer(), autoincrement=True, nullable=False),
        sa.Column("app", sa.String(length=64), nullable=False),
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("round", sa.Integer(), nullable=False),
        sa.Column("visitor_id", sa.String(length=64), nullable=False),
        sa.Column("set_name", sa.String(length=64), nullable=False),
        sa.Column("item_id", sa.String(length=64), nullable=False),
        sa.Column("answer", sa.String(length=200), nullable=False),
        sa.Column("correct", sa.Boolean(), nullable=False),
        sa.Column("answered_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_quiz_answers")),
        sa.UniqueConstraint(
            "app",
            "wall_id",
            "round",
            "visitor_id",
            "set_name",
            "item_id",
            name=op.f("uq_quiz_answers_app"),
        ),
    )
    op.create_table(
        "quiz_finishes",
        sa.Column("app", sa.String(length=64), nullable=False),
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("round", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("visitor_id", sa.String(length=64), nullable=False),
        sa.Column("set_name", sa.String(length=64), nullable=False),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=False),
        sa.PrimaryKeyConstraint(
            "app", "wall_id", "round", "visitor_id", "set_name", name=op.f("pk_quiz_finishes")
        ),
    )
    op.execute(
        f"INSERT INTO quiz_rounds (app, {ROUND_COLUMNS}) "
        f"SELECT 'brain', {ROUND_COLUMNS} FROM brain_quiz_rounds"
    )
    op.execute(
        "INSERT INTO quiz_answers (app, wall_id, round, visitor_id, set_name, item_id, answer, "
        "correct, answered_at) SELECT 'brain', wall_id, round, visitor_id, tag_set, region_id, "
        "answer, correct, answered_at FROM brain_answers ORDER BY id"
    )
    op.execute(
        "INSERT INTO quiz_finishes (app, wall_id, round, visitor_id, set_name, finished_at) "
        "SELECT 'brain', wall_id, round, visitor_id, tag_set, finished_at "
        "FROM brain_quiz_finishes"
    )
    op.drop_table("brain_quiz_finishes")
    op.drop_table("brain_answers")
    op.drop_table("brain_quiz_rounds")


def downgrade() -> None:
    """Back to the brain's own tables: its rows return; other apps' quizzes are dropped
    (no app but the brain had one before)."""
    op.create_table(
        "brain_quiz_rounds",
        sa.Column("wall_id", sa.String(length=64), nullable=False),
        sa.Column("number", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("started_by", sa.String(length=120), nullable=False),
        sa.Column("orders", sa.JSON(), nullable=False),
        sa.Column("reveal", sa.String(length=16), nullable=False),
        sa.Column("closed_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("closed_by", sa.String(length=120), nullable=True),
        sa.Column("last_answer_at", sa.DateTime(timezone=True), nullable=True),
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
    op.execute(
        f"INSERT INTO brain_quiz_rounds ({ROUND_COLUMNS}) "
        f"SELECT {ROUND_COLUMNS} FROM quiz_rounds WHERE app = 'brain'"
    )
    op.execute(
        "INSERT INTO brain_answers (wall_id, round, visitor_id, tag_set, region_id, answer, "
        "correct, answered_at) SELECT wall_id, round, visitor_id, set_name, item_id, answer, "
        "correct, answered_at FROM quiz_answers WHERE app = 'brain' ORDER BY id"
    )
    op.execute(
        "INSERT INTO brain_quiz_finishes (wall_id, round, visitor_id, tag_set, finished_at) "
        "SELECT wall_id, round, visitor_id, set_name, finished_at FROM quiz_finishes "
        "WHERE app = 'brain'"
    )
    op.drop_table("quiz_finishes")
    op.drop_table("quiz_answers")
    op.drop_table("quiz_rounds")
