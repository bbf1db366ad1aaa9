"""Program compensations run as jobs (`?async=true`) store their answer for the job's result.

- compensated_programs: the robot and the whole answer (`ProgramResponse`, the program's text with its targets
  corrected, the per-target outcomes); the request is the job's own.

Revision ID: 0009_compensated_programs
Revises: 0008_robot_fleet_key
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import create_table, created_at, drop_table, owner, uuid_key

revision = "0009_compensated_programs"
down_revision = "0008_robot_fleet_key"


def upgrade() -> None:
    create_table(
        "compensated_programs",
        uuid_key(),
        owner("robot_id", "robots"),
        sa.Column("result", sa.JSON(), nullable=False),
        created_at(),
        indexed=["robot_id"],
    )


def downgrade() -> None:
    drop_table("compensated_programs", indexed=["robot_id"])
