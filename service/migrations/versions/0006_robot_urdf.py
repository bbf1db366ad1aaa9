"""A URDF robot keeps its URDF: the calibrated export is the same document with its joint origins changed.

- robots.urdf: the URDF as imported (text; null for a robot not imported from one);
- robots.base_link, robots.tip_link: the chain it was imported between.

Revision ID: 0006_robot_urdf
Revises: 0005_checks
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006_robot_urdf"
down_revision = "0005_checks"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        batch.add_column(sa.Column("urdf", sa.Text(), nullable=True))
        batch.add_column(sa.Column("base_link", sa.String(200), nullable=True))
        batch.add_column(sa.Column("tip_link", sa.String(200), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("robots") as batch:
        for column in ("tip_link", "base_link", "urdf"):
            batch.drop_column(column)
