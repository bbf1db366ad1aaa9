"""Program compensations run as jobs (`?async=true`) store their answer for the job's result.

- compensated_programs: the robot and the whole answer (`ProgramResponse`, the program's text with its targets
  corrected, the per-target outcomes); the request is the job's own.

Revision ID: 0009_compensated_programs
Revises: 0008_robot_fleet_key
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0009_compensated_programs"
down_revision = "0008_robot_fleet_key"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "compensated_programs",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_index("ix_compensated_programs_robot_id", "compensated_programs", ["robot_id"])


def downgrade() -> None:
    op.drop_index("ix_compensated_programs_robot_id", table_name="compensated_programs")
    op.drop_table("compensated_programs")
