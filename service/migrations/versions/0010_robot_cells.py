"""A robot's cell, versioned (issue 46: poses a cell can measure).

- robot_cells: one row per version of a robot's cell, the document as sent (obstacles, instruments, link
  overrides, clearance; mm and degrees) or null for the version that ended it (DELETE), who made it and when;
  unique per (robot, version), indexed by robot.

Revision ID: 0010_robot_cells
Revises: 0009_compensated_programs
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0010_robot_cells"
down_revision = "0009_compensated_programs"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "robot_cells",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("document", sa.JSON(), nullable=True),
        sa.Column("actor", sa.String(100), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("robot_id", "version"),
    )
    op.create_index("ix_robot_cells_robot_id", "robot_cells", ["robot_id"])


def downgrade() -> None:
    op.drop_index("ix_robot_cells_robot_id", table_name="robot_cells")
    op.drop_table("robot_cells")
