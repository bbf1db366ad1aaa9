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
    document,
    drop_table,
    free_text,
    integer,
    moment,
    owner,
    reference,
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
        document("base"),
        document("tool"),
        integer("current_version"),
        created_at(),
    )
    create_robot_table(
        "parameter_versions",
        serial_key(),
        integer("version"),
        document("values"),
        document("std_errors", nullable=True),
        document("identifiable", nullable=True),
        sa.Column("provenance", sa.String(20), nullable=False),
        reference("calibration_id", nullable=True),
        created_at(),
        sa.UniqueConstraint("robot_id", "version"),
    )
    create_robot_table(
        "campaigns",
        uuid_key(),
        document("records"),
        created_at(),
    )
    create_robot_table(
        "calibrations",
        uuid_key(),
        owner("campaign_id", "campaigns"),
        sa.Column("status", sa.String(20), nullable=False),
        sa.Column("applied", sa.Boolean(), nullable=False),
        integer("parameter_version", nullable=True),
        document("result"),
        created_at(),
    )
    create_robot_table(
        "pose_designs",
        uuid_key(),
        document("request"),
        document("result"),
        created_at(),
    )
    create_table(
        "jobs",
        uuid_key(),
        sa.Column("kind", sa.String(30), nullable=False),
        reference("robot_id"),
        document("request"),
        sa.Column("status", sa.String(20), nullable=False),
        reference("result_id", nullable=True),
        document("error", nullable=True),
        created_at(),
        moment("started_at", nullable=True),
        moment("finished_at", nullable=True),
        free_text("note"),
        indexed=["robot_id", "status"],
    )


def downgrade() -> None:
    for table in ("jobs", "pose_designs", "calibrations", "campaigns", "parameter_versions", "robots"):
        drop_table(table)
