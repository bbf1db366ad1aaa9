"""Calibrations record the parameter version they started from.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import add_columns, drop_columns

revision = "0002"
down_revision = "0001"


def upgrade() -> None:
    add_columns("calibrations", sa.Column("start_version", sa.Integer(), nullable=True))


def downgrade() -> None:
    drop_columns("calibrations", "start_version")
