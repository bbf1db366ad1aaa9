"""A robot's cell, versioned (issue 46: poses a cell can measure).

- robot_cells: one row per version of a robot's cell, the document as sent (obstacles, instruments, link
  overrides, clearance; mm and degrees) or null for the version that ended it (DELETE), who made it and when;
  unique per (robot, version), indexed by robot.

Revision ID: 0010_robot_cells
Revises: 0009_compensated_programs
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import actor, created_at, document, integer, robot_table_added, serial_key

revision = "0010_robot_cells"
down_revision = "0009_compensated_programs"

upgrade, downgrade = robot_table_added(
    "robot_cells",
    serial_key(),
    integer("version"),
    document("document", nullable=True),
    actor(),
    created_at(),
    sa.UniqueConstraint("robot_id", "version"),
)
