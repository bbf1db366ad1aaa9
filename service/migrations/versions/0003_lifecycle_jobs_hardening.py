"""Schema for the calibration lifecycle, distributed jobs and writers that cannot lose each other's work.

- robots: free-text notes and a revision (the ETag of If-Match).
- parameter_versions: who made a version (the API key's name) and, for a restore, which version it copies.
- calibrations: notes and the instrument (name, serial).
- validations: measurements evaluated against parameter versions, never fitted.
- audit_events: every change of a robot or of its current version; kept when the robot is deleted.
- jobs: attempts, the lease of the worker that runs it, progress, cancellation.
- idempotency_keys: the first answer to a POST with an Idempotency-Key, replayed to retries.

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from service.migrations.shapes import (
    actor,
    add_columns,
    create_robot_table,
    create_table,
    created_at,
    document,
    drop_columns,
    drop_table,
    free_text,
    integer,
    moment,
    notes_and_instrument,
    owner,
    reference,
    serial_key,
    uuid_key,
)

revision = "0003"
down_revision = "0002"


def upgrade() -> None:
    add_columns(
        "robots",
        free_text("notes"),
        sa.Column("revision", sa.Integer(), nullable=False, server_default="1"),
    )
    add_columns("parameter_versions", actor(), integer("restored_from", nullable=True))
    add_columns("calibrations", *notes_and_instrument())
    add_columns(
        "jobs",
        sa.Column("attempts", sa.Integer(), nullable=False, server_default="0"),
        sa.Column("worker", sa.String(200), nullable=True),
        moment("lease_expires_at", nullable=True),
        document("progress", nullable=True),
        sa.Column("cancel_requested", sa.Boolean(), nullable=False, server_default=sa.false()),
    )
    op.create_index("ix_jobs_lease_expires_at", "jobs", ["lease_expires_at"])
    create_robot_table(
        "validations",
        uuid_key(),
        owner("campaign_id", "campaigns"),
        document("result"),
        *notes_and_instrument(),
        created_at(),
    )
    create_table(
        "audit_events",
        serial_key(),
        moment("at"),
        actor(),
        sa.Column("request_id", sa.String(64), nullable=True),
        sa.Column("action", sa.String(40), nullable=False),
        # No foreign key: the trail of a deleted robot stays.
        reference("robot_id", nullable=True),
        integer("version", nullable=True),
        document("details", nullable=True),
        indexed=["robot_id", "at"],
    )
    create_table(
        "idempotency_keys",
        sa.Column("actor", sa.String(100), primary_key=True),
        sa.Column("key", sa.String(200), primary_key=True),
        sa.Column("method", sa.String(10), nullable=False),
        sa.Column("path", sa.String(500), nullable=False),
        sa.Column("body_sha256", sa.String(64), nullable=False),
        integer("status", nullable=True),
        sa.Column("content_type", sa.String(100), nullable=True),
        sa.Column("body", sa.LargeBinary(), nullable=True),
        created_at(),
        moment("expires_at"),
        indexed=["expires_at"],
    )


def downgrade() -> None:
    for table in ("idempotency_keys", "audit_events", "validations"):
        drop_table(table)
    op.drop_index("ix_jobs_lease_expires_at", "jobs")
    drop_columns("jobs", "cancel_requested", "progress", "lease_expires_at", "worker", "attempts")
    drop_columns("calibrations", "instrument", "notes")
    drop_columns("parameter_versions", "restored_from", "actor")
    drop_columns("robots", "revision", "notes")
