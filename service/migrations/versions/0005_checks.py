"""Quick checks (models.evaluation.checks): a few records against the current version, with their verdict.

- checks: the campaign it measured, the version it was checked against, the verdict and the whole result.

Revision ID: 0005_checks
Revises: 0004_structures
"""

from __future__ import annotations

import sqlalchemy as sa

from service.migrations.shapes import (
    created_at,
    document,
    integer,
    notes_and_instrument,
    owner,
    robot_table_added,
    uuid_key,
)

revision = "0005_checks"
down_revision = "0004_structures"

upgrade, downgrade = robot_table_added(
    "checks",
    uuid_key(),
    owner("campaign_id", "campaigns"),
    integer("version"),
    sa.Column("verdict", sa.String(20), nullable=False),
    document("result"),
    *notes_and_instrument(),
    created_at(),
)
