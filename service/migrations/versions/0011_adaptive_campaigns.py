"""Adaptive campaigns (docs/pose-design.md "Adaptive campaigns"): every step stored, so a restart resumes.

- adaptive_campaigns: the robot, its start version, the request, the candidate pool, the state after the last
  step, the calibration a finish stored;
- adaptive_steps: each post of records and its answer, numbered per campaign (unique).

Revision ID: 0011_adaptive_campaigns
Revises: 0010_robot_cells
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0011_adaptive_campaigns"
down_revision = "0010_robot_cells"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "adaptive_campaigns",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("request", sa.JSON(), nullable=False),
        sa.Column("pool", sa.JSON(), nullable=False),
        sa.Column("state", sa.JSON(), nullable=False),
        sa.Column("steps", sa.Integer(), nullable=False),
        sa.Column("calibration_id", sa.String(36), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("updated_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_index("ix_adaptive_campaigns_robot_id", "adaptive_campaigns", ["robot_id"])
    op.create_table(
        "adaptive_steps",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column(
            "campaign_id", sa.String(36), sa.ForeignKey("adaptive_campaigns.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("number", sa.Integer(), nullable=False),
        sa.Column("records", sa.JSON(), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("campaign_id", "number", name="uq_adaptive_steps_campaign_number"),
    )
    op.create_index("ix_adaptive_steps_campaign_id", "adaptive_steps", ["campaign_id"])


def downgrade() -> None:
    op.drop_index("ix_adaptive_steps_campaign_id", table_name="adaptive_steps")
    op.drop_table("adaptive_steps")
    op.drop_index("ix_adaptive_campaigns_robot_id", table_name="adaptive_campaigns")
    op.drop_table("adaptive_campaigns")
