"""Robots of several chains (issue 47: cells of several chains).

- robot_trees: one row per tree: its name, its tree document as built (branches, mounts, stages, tools; mm and
  degrees), where it came from (a document or a URDF, kept with its base and tip links), its revision (the
  ETag) and its current parameters (internal units; null: nominal) with their standard errors and the
  calibration that set them.
- robot_tree_calibrations: each calibration of a tree: its records as received, its answer, whether it was
  applied and the revision it made; deleted with its tree, indexed by tree.

Revision ID: 0012_robot_trees
Revises: 0011_adaptive_campaigns
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0012_robot_trees"
down_revision = "0011_adaptive_campaigns"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "robot_trees",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("document", sa.JSON(), nullable=False),
        sa.Column("source", sa.String(20), nullable=False),
        sa.Column("urdf", sa.Text(), nullable=True),
        sa.Column("base_link", sa.String(200), nullable=True),
        sa.Column("tip_links", sa.JSON(), nullable=True),
        sa.Column("revision", sa.Integer(), nullable=False),
        sa.Column("parameters", sa.JSON(), nullable=True),
        sa.Column("std_errors", sa.JSON(), nullable=True),
        sa.Column("calibration_id", sa.String(36), nullable=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("actor", sa.String(100), nullable=True),
    )
    op.create_table(
        "robot_tree_calibrations",
        sa.Column("id", sa.String(36), primary_key=True),
        sa.Column("tree_id", sa.String(36), sa.ForeignKey("robot_trees.id", ondelete="CASCADE"), nullable=False),
        sa.Column("applied", sa.Boolean(), nullable=False),
        sa.Column("revision", sa.Integer(), nullable=True),
        sa.Column("start_revision", sa.Integer(), nullable=False),
        sa.Column("records", sa.JSON(), nullable=False),
        sa.Column("result", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("actor", sa.String(100), nullable=True),
    )
    op.create_index("ix_robot_tree_calibrations_tree_id", "robot_tree_calibrations", ["tree_id"])


def downgrade() -> None:
    op.drop_index("ix_robot_tree_calibrations_tree_id", table_name="robot_tree_calibrations")
    op.drop_table("robot_tree_calibrations")
    op.drop_table("robot_trees")
