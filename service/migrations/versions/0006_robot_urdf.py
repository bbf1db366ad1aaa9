"""A URDF robot keeps its URDF: the calibrated export is the same document with its joint origins changed.

- robots.urdf: the URDF as imported (text; null for a robot not imported from one);
- robots.base_link, robots.tip_link: the chain it was imported between.

Revision ID: 0006_robot_urdf
Revises: 0005_checks
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import columns_added, free_text

revision = "0006_robot_urdf"
down_revision = "0005_checks"

upgrade, downgrade = columns_added(
    "robots",
    free_text("urdf"),
    sa.Column("base_link", sa.String(200), nullable=True),
    sa.Column("tip_link", sa.String(200), nullable=True),
)
