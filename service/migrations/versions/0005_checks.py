"""Quick checks (models.evaluation.checks): a few records against the current version, with their verdict.

- checks: the campaign it measured, the version it was checked against, the verdict and the whole result.

Revision ID: 0005_checks
Revises: 0004_structures
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005_checks"
down_revision = "0004_structures"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "checks",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("robot_id", sa.String(36), sa.ForeignKey("robots.id", ondelete="CASCADE"), nullable=False),
        sa.Column("campaign_id", sa.String(36), sa.ForeignKey("campaigns.id", ondelete="CASCADE"), nullable=False),
        sa.Column("version", sa.Integer(), nullable=False),
        sa.Column("verdict", sa.String(20), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        sa.Column("notes", sa.Text(), nullable=True),
        sa.Column("instrument", sa.JSON(), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
    )
    op.create_index("ix_checks_robot_id", "checks", ["robot_id"])


def downgrade() -> None:
    op.drop_index("ix_checks_robot_id", table_name="checks")
    op.drop_table("checks")
