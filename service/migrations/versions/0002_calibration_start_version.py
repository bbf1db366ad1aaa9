"""Calibrations record the parameter version they started from.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import columns_added

revision = "0002"
down_revision = "0001"

upgrade, downgrade = columns_added("calibrations", sa.Column("start_version", sa.Integer(), nullable=True))
