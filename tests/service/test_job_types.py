"""Job kinds are declared once: the kinds the API's schema names (`JobKind`), the kinds the operations become with
`?async=true` (`@operation(job=...)`) and the use cases that run them (`service.services.jobs.JOB_TYPES`) are
the same set, so a kind cannot be queued that no worker runs, nor run with no result to show."""

from __future__ import annotations

from typing import get_args

from service.http.app import create_app
from service.http.operations import table
from service.schemas.jobs import JobKind
from service.services.jobs import JOB_TYPES
from service.settings import Settings


def test_every_job_kind_is_declared_run_and_shown_once() -> None:
    app = create_app(Settings(database_url="sqlite://", job_workers=0, warm_up=False, background_builds=False))
    declared = {op.job for op in table(app).values() if op is not None and op.job is not None}
    assert set(get_args(JobKind)) == set(JOB_TYPES) == declared
