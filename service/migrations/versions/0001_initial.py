"""Initial schema: robots, parameter versions, campaigns, calibrations, pose designs, jobs.

Revision ID: 0001
Revises:
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import (
    create_robot_table,
    create_table,
    created_at,
    drop_table,
    moment,
    owner,
    serial_key,
    uuid_key,
)

revision = "0001"
down_revision = None


def upgrade() -> None:
    create_table(
        "robots",
        uuid_key(),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("model", sa.String(20), nullable=False),
        sa.Column("base", sa.JSON(), nullable=False),
        sa.Column("tool", sa.JSON(), nullable=False),
        sa.Column("current_version", sa.Integer(), nullable=False),
        created_at(),
    )
    create_robot_table(
        "parameter_versions",
        serial_key(),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("values", sa.JSON(), nullable=False),
        sa.Column("std_errors", sa.JSON(), nullable=True),
        sa.Column("identifiable", sa.JSON(), nullable=True),
        sa.Column("provenance", sa.String(20), nullable=False),
        sa.Column("calibration_id", sa.String(36), nullable=True),
        created_at(),
        sa.UniqueConstraint("robot_id", "version"),
    )
    create_robot_table(
        "campaigns",
        uuid_key(),
        sa.Column("records", sa.JSON(), nullable=False),
        created_at(),
    )
    create_robot_table(
        "calibrations",
        uuid_key(),
        owner("campaign_id", "campaigns"),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("applied", sa.Boolean(), nullable=False),
        sa.Column("parameter_version", sa.Integer(), nullable=True),
        sa.Column("result", sa.JSON(), nullable=False),
        created_at(),
    )
    create_robot_table(
        "pose_designs",
        uuid_key(),
        sa.Column("request", sa.JSON(), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        created_at(),
    )
    create_table(
        "jobs",
        uuid_key(),
        sa.Column("kind", sa.String(30), nullable=False),
        sa.Column("robot_id", sa.String(36), nullable=False),
        sa.Column("request", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("result_id", sa.String(36), nullable=True),
        sa.Column("error", sa.JSON(), nullable=True),
        created_at(),
        moment("started_at", nullable=True),
        moment("finished_at", nullable=True),
        sa.Column("note", sa.Text(), nullable=True),
        indexed=["robot_id", "status"],
    )


def downgrade() -> None:
    for table in ("jobs", "pose_designs", "calibrations", "campaigns", "parameter_versions", "robots"):
        drop_table(table)
