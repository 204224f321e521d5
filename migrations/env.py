"""Alembic environment: the URL comes from tagwall's settings; batch mode for SQLite."""

from alembic import context

import webapp.database.models  # noqa: F401  (registers the tables)
from webapp.core.settings import Settings
from webapp.database.connection import Base, make_engine

config = context.config
url = config.get_main_option("sqlalchemy.url") or Settings().resolved_database_url
# An app's own revisions keep their history in a table of their own (webapp.database.migrate).
version_table = config.get_main_option("version_table") or "alembic_version"


def run_migrations_offline() -> None:
    context.configure(
        url=url,
        target_metadata=Base.metadata,
        literal_binds=True,
        render_as_batch=True,
        version_table=version_table,
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    engine = make_engine(url)
    with engine.connect() as connection:
        context.configure(
            connection=connection,
            target_metadata=Base.metadata,
            render_as_batch=True,
            version_table=version_table,
        )
        with context.begin_transaction():
            context.run_migrations()
    engine.dispose()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
