"""The columns and table operations the revisions in versions/ share. FROZEN: never change a helper here.

A revision's effect is history: databases in plants stand at any revision and upgrade through these files, so a
revision must make tomorrow the schema it made the day it was written. Every helper below is part of each revision
that calls it; editing one would change what those old revisions do (a database upgraded after the edit would get
another schema than one upgraded before). A new shape gets a new helper, or is spelled out in its revision.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import sqlalchemy as sa
from alembic import op

Step = Callable[[], None]
"""A revision's `upgrade` or `downgrade`."""


def uuid_key() -> sa.Column[Any]:
    """The primary key `id` of a table whose rows are named by a UUID (text)."""
    return sa.Column("id", sa.String(36), primary_key=True)


def serial_key() -> sa.Column[Any]:
    """The primary key `id` of a table whose rows the database numbers."""
    return sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True)


def owner(column: str, table: str) -> sa.Column[Any]:
    """The UUID of the row (of `table`) this one belongs to: required, and the row goes when its owner does."""
    return sa.Column(column, sa.String(36), sa.ForeignKey(f"{table}.id", ondelete="CASCADE"), nullable=False)


def moment(name: str, *, nullable: bool = False) -> sa.Column[Any]:
    """A point in time, with its time zone."""
    return sa.Column(name, sa.DateTime(timezone=True), nullable=nullable)


def created_at() -> sa.Column[Any]:
    """When the row was stored."""
    return moment("created_at")


def actor() -> sa.Column[Any]:
    """Who made the row: the API key's name (null where there was none)."""
    return sa.Column("actor", sa.String(100), nullable=True)


def document(name: str, *, nullable: bool = False) -> sa.Column[Any]:
    """A JSON document (a request, a result, parameters, records as received)."""
    return sa.Column(name, sa.JSON(), nullable=nullable)


def integer(name: str, *, nullable: bool = False) -> sa.Column[Any]:
    """A whole number (a version, a revision, a count)."""
    return sa.Column(name, sa.Integer(), nullable=nullable)


def free_text(name: str) -> sa.Column[Any]:
    """Text of any length, optional (notes, a URDF as sent)."""
    return sa.Column(name, sa.Text(), nullable=True)


def reference(name: str, *, nullable: bool = False) -> sa.Column[Any]:
    """The UUID of a row elsewhere, with no foreign key: the row may go before this one, or be of one of several
    tables."""
    return sa.Column(name, sa.String(36), nullable=nullable)


def notes_and_instrument() -> tuple[sa.Column[Any], sa.Column[Any]]:
    """What a fit of a campaign (calibration, validation, check) was told: free-text notes and the instrument
    (name, serial), both optional."""
    return sa.Column("notes", sa.Text(), nullable=True), sa.Column("instrument", sa.JSON(), nullable=True)


def index_name(table: str, column: str) -> str:
    """Every index of this schema is on one column and named after it."""
    return f"ix_{table}_{column}"


def create_table(name: str, *columns: sa.Column[Any] | sa.Constraint, indexed: Sequence[str] = ()) -> None:
    """The table, then an index on each of the `indexed` columns (in that order)."""
    op.create_table(name, *columns)
    for column in indexed:
        op.create_index(index_name(name, column), name, [column])


def drop_table(name: str, *, indexed: Sequence[str] = ()) -> None:
    """The indexes on the `indexed` columns (in that order), then the table."""
    for column in indexed:
        op.drop_index(index_name(name, column), table_name=name)
    op.drop_table(name)


def create_robot_table(name: str, key: sa.Column[Any], *columns: sa.Column[Any] | sa.Constraint) -> None:
    """A table of a robot's rows: its `key`, the robot each row belongs to (`robot_id`, indexed), then `columns`."""
    create_table(name, key, owner("robot_id", "robots"), *columns, indexed=["robot_id"])


def drop_robot_table(name: str) -> None:
    """A table `create_robot_table` made, with its index."""
    drop_table(name, indexed=["robot_id"])


def add_columns(table: str, *columns: sa.Column[Any]) -> None:
    """The columns added to `table` in one batch (on SQLite: one copy of the table)."""
    with op.batch_alter_table(table) as batch:
        for column in columns:
            batch.add_column(column)


def drop_columns(table: str, *names: str) -> None:
    """The columns dropped from `table` in one batch, in the order named (a downgrade names them last added
    first)."""
    with op.batch_alter_table(table) as batch:
        for name in names:
            batch.drop_column(name)


def columns_added(table: str, *columns: sa.Column[Any]) -> tuple[Step, Step]:
    """The `upgrade` and `downgrade` of a revision that only adds `columns` to `table`, from the one list: the
    upgrade adds them (`add_columns`), the downgrade drops them, last added first (`drop_columns`). Alembic copies a
    column an earlier run attached to a table (operations/toimpl.py add_column), so the one list serves every
    database a process migrates."""

    def upgrade() -> None:
        add_columns(table, *columns)

    def downgrade() -> None:
        drop_columns(table, *(column.name for column in reversed(columns)))

    return upgrade, downgrade


def robot_table_added(name: str, key: sa.Column[Any], *columns: sa.Column[Any] | sa.Constraint) -> tuple[Step, Step]:
    """The `upgrade` and `downgrade` of a revision that only adds a table of a robot's rows, from the one list: the
    upgrade creates it (`create_robot_table`), the downgrade drops it (`drop_robot_table`). Alembic copies the
    columns and constraints an earlier run attached to a table (operations/schemaobj.py SchemaObjects.table), as
    for `columns_added`."""

    def upgrade() -> None:
        create_robot_table(name, key, *columns)

    def downgrade() -> None:
        drop_robot_table(name)

    return upgrade, downgrade
