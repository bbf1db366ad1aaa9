"""What a job adds to a use case: progress points, and its own final state in the use case's write transaction.

The synchronous routes pass nothing (`job=None`) and behave as before; a job worker passes its hooks, so its
result, any new parameter version and the job's `succeeded` commit together or not at all.
"""

from __future__ import annotations

from typing import Protocol

from sqlalchemy.orm import Session


class JobHooks(Protocol):
    def progress(self, stage: str, fraction: float) -> None:
        """A point where the job may stop: raises when it was cancelled or its worker lost the lease."""

    def commit(self, session: Session, result_id: str) -> None:
        """Inside the use case's write transaction, after its writes: mark the job done, or raise (and roll
        everything back) when this worker no longer holds it."""
