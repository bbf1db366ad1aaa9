"""Alembic environment: migrations run on the connection the service hands over (see persistence.database)."""

from __future__ import annotations

from alembic import context
from sqlalchemy import Connection, create_engine

from service.persistence.tables import Base


def run_migrations(connection: Connection) -> None:
    context.configure(connection=connection, target_metadata=Base.metadata, render_as_batch=True)
    with context.begin_transaction():
        context.run_migrations()


config = context.config
connection = config.attributes.get("connection")
if connection is None:  # the alembic command line
    engine = create_engine(config.get_main_option("sqlalchemy.url") or "sqlite:///./data/iwr.db")
    with engine.begin() as conn:
        run_migrations(conn)
else:
    run_migrations(connection)
