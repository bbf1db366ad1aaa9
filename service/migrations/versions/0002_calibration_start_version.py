"""Calibrations record the parameter version they started from.

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

from service.migrations.shapes import columns_added, integer

revision = "0002"
down_revision = "0001"

upgrade, downgrade = columns_added("calibrations", integer("start_version", nullable=True))
