"""Adaptive campaigns (docs/pose-design.md "Adaptive campaigns"): every step stored, so a restart resumes.

- adaptive_campaigns: the robot, its start version, the request, the candidate pool, the state after the last
  step, the calibration a finish stored;
- adaptive_steps: each post of records and its answer, numbered per campaign (unique).

Revision ID: 0011_adaptive_campaigns
Revises: 0010_robot_cells
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import (
    create_robot_table,
    create_table,
    created_at,
    document,
    drop_robot_table,
    drop_table,
    integer,
    moment,
    owner,
    reference,
    uuid_key,
)

revision = "0011_adaptive_campaigns"
down_revision = "0010_robot_cells"


def upgrade() -> None:
    create_robot_table(
        "adaptive_campaigns",
        uuid_key(),
        integer("version"),
        document("request"),
        document("pool"),
        document("state"),
        integer("steps"),
        reference("calibration_id", nullable=True),
        created_at(),
        moment("updated_at"),
    )
    create_table(
        "adaptive_steps",
        uuid_key(),
        owner("campaign_id", "adaptive_campaigns"),
        integer("number"),
        document("records"),
        document("result"),
        created_at(),
        sa.UniqueConstraint("campaign_id", "number", name="uq_adaptive_steps_campaign_number"),
        indexed=["campaign_id"],
    )


def downgrade() -> None:
    drop_table("adaptive_steps", indexed=["campaign_id"])
    drop_robot_table("adaptive_campaigns")
