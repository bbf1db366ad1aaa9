"""Robots of any structure: the robot's description document (shared/spec/robots.md).

- robots.structure: the document a robot was created from (JSON; null for the built-in IWR).

Revision ID: 0004_structures
Revises: 0003
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004_structures"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("structure", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.drop_column("structure")
