"""The migrations build exactly the schema the ORM declares, on SQLite and on PostgreSQL; 0008 fills the robots' fleet
keys."""

from __future__ import annotations

import json
from pathlib import Path

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.config import Config
from alembic.migration import MigrationContext
from sqlalchemy import create_engine, text

from models.examples import ur5_like_document
from service.persistence import Database
from service.persistence.database import MIGRATIONS
from service.persistence.tables import Base, Robot, fleet_key_of


def test_migrations_match_the_declared_tables(db: Database) -> None:
    with db.engine.connect() as connection:
        context = MigrationContext.configure(connection, opts={"compare_type": True})
        differences = compare_metadata(context, Base.metadata)
    assert differences == [], differences


def test_migration_0008_fills_each_robots_fleet_key_as_new_robots_get_theirs(tmp_path: Path) -> None:
    """Robots stored before 0008 (the IWR, two UR5-like arms with their own base and tool guesses, a 3R arm) get
    the key a robot created now gets: one key for the two arms, whatever their base and tool."""
    url = f"sqlite:///{tmp_path}/old.db"
    engine = create_engine(url)
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    config.set_main_option("sqlalchemy.url", url)
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0007_version_conditions")
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
    with engine.begin() as connection:
        for name, document in documents.items():
            connection.execute(insert, {"id": name, "structure": None if document is None else json.dumps(document)})
    engine.dispose()

    db = Database(url)
    try:
        db.migrate()
        with db.reader() as s:
            keys = {robot.id: robot.fleet_key for robot in s.query(Robot)}
    finally:
        db.dispose()
    assert keys == {name: fleet_key_of(document) for name, document in documents.items()}
    assert keys["arm-a"] == keys["arm-b"] != keys["3r"] != keys["iwr"]
