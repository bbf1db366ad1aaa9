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

from service.migrations.shapes import (
    actor,
    create_table,
    created_at,
    document,
    drop_table,
    free_text,
    integer,
    owner,
    reference,
    uuid_key,
)

revision = "0012_robot_trees"
down_revision = "0011_adaptive_campaigns"


def upgrade() -> None:
    create_table(
        "robot_trees",
        uuid_key(),
        sa.Column("name", sa.String(200), nullable=False),
        document("document"),
        sa.Column("source", sa.String(20), nullable=False),
        free_text("urdf"),
        sa.Column("base_link", sa.String(200), nullable=True),
        document("tip_links", nullable=True),
        integer("revision"),
        document("parameters", nullable=True),
        document("std_errors", nullable=True),
        reference("calibration_id", nullable=True),
        created_at(),
        actor(),
    )
    create_table(
        "robot_tree_calibrations",
        uuid_key(),
        owner("tree_id", "robot_trees"),
        sa.Column("applied", sa.Boolean(), nullable=False),
        integer("revision", nullable=True),
        integer("start_revision"),
        document("records"),
        document("result"),
        created_at(),
        actor(),
        indexed=["tree_id"],
    )


def downgrade() -> None:
    drop_table("robot_tree_calibrations", indexed=["tree_id"])
    drop_table("robot_trees")
