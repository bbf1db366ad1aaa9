"""A version remembers what the campaign that made it was measured under.

- parameter_versions.conditions: the temperature and payload ranges, the first and last record's time and the
  duration of the calibration's campaign (JSON; null for versions no campaign made, and for those stored
  before); later checks and compensations warn when they run the robot outside them.

Revision ID: 0007_version_conditions
Revises: 0006_robot_urdf
"""

from __future__ import annotations

from service.migrations.shapes import columns_added, document

revision = "0007_version_conditions"
down_revision = "0006_robot_urdf"

upgrade, downgrade = columns_added("parameter_versions", document("conditions", nullable=True))
