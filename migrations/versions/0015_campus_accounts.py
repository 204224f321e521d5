"""Campus accounts: an account may sign in through an OpenID provider instead of a
password (``issuer`` and ``subject`` name the person there; ``full_name`` as the provider
gives it).

Revision ID: 0015
Revises: 0014
Create Date: 2026-12-09
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0015"
down_revision: str | None = "0014"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table("accounts", schema=None) as batch_op:
        batch_op.alter_column("password_hash", existing_type=sa.String(200), nullable=True)
        batch_op.add_column(sa.Column("issuer", sa.String(500), nullable=True))
        batch_op.add_column(sa.Column("subject", sa.String(255), nullable=True))
        batch_op.add_column(
            sa.Column("full_name", sa.String(80), nullable=False, server_default="")
        )
        batch_op.create_unique_constraint(op.f("uq_accounts_issuer"), ["issuer", "subject"])
    with op.batch_alter_table("accounts", schema=None) as batch_op:
        batch_op.alter_column("full_name", server_default=None)


def downgrade() -> None:
    """Back to password accounts only: campus accounts, which have none, are removed
    (the phones they signed in keep an authority no account holds, and count as
    students once their session is read against no account)."""
    accounts = sa.table("accounts", sa.column("password_hash", sa.String(200)))
    op.execute(accounts.delete().where(accounts.c.password_hash.is_(None)))
    with op.batch_alter_table("accounts", schema=None) as batch_op:
        batch_op.drop_constraint(op.f("uq_accounts_issuer"), type_="unique")
        batch_op.drop_column("full_name")
        batch_op.drop_column("subject")
        batch_op.drop_column("issuer")
        batch_op.alter_column("password_hash", existing_type=sa.String(200), nullable=False)
