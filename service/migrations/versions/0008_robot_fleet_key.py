"""A robot stores its fleet's key.

- robots.fleet_key: a digest of the robot's structure document without its base and tool guesses (the IWR's:
  of "iwr"), indexed: a fleet (its population, a calibration's prior and comparison) is read by one query on it,
  where every robot's document was read and digested before (a calibration cost +40 ms at 1 000 robots). Filled
  here for the robots stored before, with a frozen copy of `service.persistence.tables.fleet_key_of`.

Revision ID: 0008_robot_fleet_key
Revises: 0007_version_conditions
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import sqlalchemy as sa
from alembic import op

revision = "0008_robot_fleet_key"
down_revision = "0007_version_conditions"


def _key(structure: dict[str, Any] | None) -> str:
    document: object = "iwr" if structure is None else {k: v for k, v in structure.items() if k not in ("base", "tool")}
    canonical = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("fleet_key", sa.String(16), nullable=True))
        batch.create_index("ix_robots_fleet_key", ["fleet_key"])
    robots = sa.table("robots", sa.column("id", sa.String), sa.column("structure", sa.JSON), sa.column("fleet_key"))
    bind = op.get_bind()
    for robot_id, structure in bind.execute(sa.select(robots.c.id, robots.c.structure)).all():
        bind.execute(robots.update().where(robots.c.id == robot_id).values(fleet_key=_key(structure)))
    with op.batch_alter_table("robots") as batch:  # every robot has one now, and every new one gets one
        batch.alter_column("fleet_key", existing_type=sa.String(16), nullable=False)


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.drop_index("ix_robots_fleet_key")
        batch.drop_column("fleet_key")
