"""Robots of any structure: the robot's description document (shared/spec/robots.md).

- robots.structure: the document a robot was created from (JSON; null for the built-in IWR).

Revision ID: 0004_structures
Revises: 0003
"""

from __future__ import annotations

from service.migrations.shapes import columns_added, document

revision = "0004_structures"
down_revision = "0003"

upgrade, downgrade = columns_added("robots", document("structure", nullable=True))
