"""Program compensations run as jobs (`?async=true`) store their answer for the job's result.

- compensated_programs: the robot and the whole answer (`ProgramResponse`, the program's text with its targets
  corrected, the per-target outcomes); the request is the job's own.

Revision ID: 0009_compensated_programs
Revises: 0008_robot_fleet_key
"""

from __future__ import annotations

from service.migrations.shapes import created_at, document, robot_table_added, uuid_key

revision = "0009_compensated_programs"
down_revision = "0008_robot_fleet_key"

upgrade, downgrade = robot_table_added(
    "compensated_programs",
    uuid_key(),
    document("result"),
    created_at(),
)
