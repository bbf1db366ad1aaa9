"""The migrations build exactly the schema the ORM declares, on SQLite and on PostgreSQL; 0008 fills the robots' fleet
keys; 0009 and 0010 add their tables (and indexes, unique constraints) and their downgrades remove them."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import text

from models.description.examples import ur5_like_document
from service.persistence import Database
from service.persistence.tables import Base, Robot, fleet_key_of
from tests.service.helpers import TableShape, migrated_file


def test_migrations_match_the_declared_tables(db: Database) -> None:
    with db.engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        differences = compare_metadata(context, Base.metadata)
    assert differences == [], differences


def test_migration_0008_fills_each_robots_fleet_key_as_new_robots_get_theirs(tmp_path: Path) -> None:
    """Robots stored before 0008 (the IWR, two UR5-like arms with their own base and tool guesses, a 3R arm) get
    the key a robot created now gets: one key for the two arms, whatever their base and tool."""
    arm = ur5_like_document()
    documents = {
        "iwr": None,
        "arm-a": {**arm, "base": {"position": [1.0, 2.0, 3.0]}},
        "arm-b": {**arm, "tool": {"position": [0.0, 0.0, 150.0]}},
        "3r": {"stages": [{"kind": "serial", "convention": "dh", "links": [{"joint": "revolute", "a": 100.0}] * 3}]},
    }
    insert = text(
        "INSERT INTO robots (id, name, model, base, tool, current_version, created_at, revision, structure) "
        "VALUES (:id, :id, 'custom', '[]', '[]', 1, '2026-01-01 00:00:00', 1, :structure)"
    )
    with migrated_file(tmp_path / "old.db") as old:
        old.upgrade("0007_version_conditions")
        with old.engine.begin() as connection:
            for name, document in documents.items():
                structure = None if document is None else json.dumps(document)
                connection.execute(insert, {"id": name, "structure": structure})

    db = Database(old.url)
    try:
        db.migrate()
        with db.reader() as s:
            keys = {robot.id: robot.fleet_key for robot in s.query(Robot)}
    finally:
        db.dispose()
    assert keys == {name: fleet_key_of(document) for name, document in documents.items()}
    assert keys["arm-a"] == keys["arm-b"] != keys["3r"] != keys["iwr"]


@pytest.mark.parametrize(
    ("before", "revision", "added"),
    [
        (
            "0008_robot_fleet_key",
            "0009_compensated_programs",
            {"compensated_programs": (frozenset({"ix_compensated_programs_robot_id"}), ())},
        ),
        (
            "0009_compensated_programs",
            "0010_robot_cells",
            {"robot_cells": (frozenset({"ix_robot_cells_robot_id"}), (("robot_id", "version"),))},
        ),
    ],
)
def test_a_migration_adds_its_tables_and_its_downgrade_leaves_the_schema_before_it(
    tmp_path: Path, before: str, revision: str, added: dict[str, TableShape]
) -> None:
    with migrated_file(tmp_path / "old.db") as old:
        old.upgrade(before)
        tables = old.tables()
        old.upgrade(revision)
        upgraded = old.tables()
        old.downgrade(before)
        assert {name: upgraded[name] for name in upgraded.keys() - tables.keys()} == added
        assert old.tables() == tables
