"""Readable labels for the shipped Sacramento data set where it was seeded before they
were: its three occupation columns read as words, not as their column codes.

The seed imports the shipped data set once, so a database seeded earlier kept the
labels of that day; this gives it today's (the same as content/census/
sacramento-2000.toml). Settings an instructor edited since are left alone.

Revision ID: 0010
Revises: 0009
Create Date: 2026-12-08
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0010"
down_revision: str | None = "0009"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

READABLE = {
    "Employed civilians: OCC_MAN occupation group": (
        "Employed civilians in production occupations"
    ),
    "Employed civilians: OCC_OFF1 occupation group": (
        "Employed civilians in management, business, computing, engineering, science, "
        "social service and legal occupations"
    ),
    "Employed civilians: OCC_INFO occupation group": (
        "Employed civilians in computer and mathematical occupations"
    ),
}

datasets = sa.table("census_datasets", sa.column("id", sa.Integer), sa.column("settings", sa.JSON))


def upgrade() -> None:
    connection = op.get_bind()
    for dataset_id, settings in connection.execute(sa.select(datasets.c.id, datasets.c.settings)):
        attributes = settings.get("attributes", []) if isinstance(settings, dict) else []
        if not any(a.get("label") in READABLE for a in attributes):
            continue
        renamed = [{**a, "label": READABLE.get(a.get("label"), a.get("label"))} for a in attributes]
        connection.execute(
            datasets.update()
            .where(datasets.c.id == dataset_id)
            .values(settings={**settings, "attributes": renamed})
        )


def downgrade() -> None:
    """Nothing to undo: the labels were only ever words for the same columns."""
