"""Initial schema: robots, parameter versions, campaigns, calibrations, pose designs, jobs.

Revision ID: 0001
Revises:
"""

from __future__ import annotations

from typing import Any

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def _created() -> sa.Column[Any]:
    return sa.Column("created_at", sa.DateTime(timezone=True), nullable=False)


def upgrade() -> None:
    op.create_table(
        "robots",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("model", sa.String(20), nullable=False),
        sa.Column("base", sa.JSON(), nullable=False),
        sa.Column("tool", sa.JSON(), nullable=False),
        sa.Column("current_version", sa.Integer(), nullable=False),
        _created(),
    )
    op.create_table(
        "parameter_versions",
        sa.Column("id", sa.Integer(), primary_key=True, autoincrement=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("values", sa.JSON(), nullable=False),
        sa.Column("std_errors", sa.JSON(), nullable=True),
        sa.Column("identifiable", sa.JSON(), nullable=True),
        sa.Column("provenance", sa.String(20), nullable=False),
        sa.Column("calibration_id", sa.String(36), nullable=True),
        _created(),
        sa.UniqueConstraint("robot_id", "version"),
    )
    op.create_index("ix_parameter_versions_robot_id", "parameter_versions", ["robot_id"])
    op.create_table(
        "campaigns",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("records", sa.JSON(), nullable=False),
        _created(),
    )
    op.create_index("ix_campaigns_robot_id", "campaigns", ["robot_id"])
    op.create_table(
        "calibrations",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("campaign_id", sa.String(36), sa.ForeignKey("campaigns.id", ondelete="CASCADE"), nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("applied", sa.Boolean(), nullable=False),
        sa.Column("parameter_version", sa.Integer(), nullable=True),
        sa.Column("result", sa.JSON(), nullable=False),
        _created(),
    )
    op.create_index("ix_calibrations_robot_id", "calibrations", ["robot_id"])
    op.create_table(
        "pose_designs",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("request", sa.JSON(), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        _created(),
    )
    op.create_index("ix_pose_designs_robot_id", "pose_designs", ["robot_id"])
    op.create_table(
        "jobs",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("kind", sa.String(30), nullable=False),
        sa.Column("robot_id", sa.String(36), nullable=False),
        sa.Column("request", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("result_id", sa.String(36), nullable=True),
        sa.Column("error", sa.JSON(), nullable=True),
        _created(),
        sa.Column("started_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=True),
        sa.Column("note", sa.Text(), nullable=True),
    )
    op.create_index("ix_jobs_robot_id", "jobs", ["robot_id"])
    op.create_index("ix_jobs_status", "jobs", ["status"])


def downgrade() -> None:
    for table in ("jobs", "pose_designs", "calibrations", "campaigns", "parameter_versions", "robots"):
        op.drop_table(table)
