"""What a request to the service can end in besides an answer: a problem (RFC 9457), an unreachable service, a
job that ended without a result, a campaign file the client cannot read."""

from __future__ import annotations

from typing import Any


class ApiError(Exception):
    """The service answered with an error status. `problem` is its RFC 9457 document as sent (an answer that was
    not a problem, such as a proxy's HTML page, becomes one with the status and the body's start as its detail)."""

    def __init__(self, problem: dict[str, Any]) -> None:
        self.problem = problem
        super().__init__(f"{self.status} {self.title}: {self.detail}")

    @property
    def status(self) -> int:
        return int(self.problem.get("status") or 0)

    @property
    def type(self) -> str:
        return str(self.problem.get("type", "about:blank"))

    @property
    def title(self) -> str:
        return str(self.problem.get("title", ""))

    @property
    def detail(self) -> str:
        return str(self.problem.get("detail", ""))

    @property
    def extensions(self) -> dict[str, Any]:
        """The members beyond RFC 9457's own (which record, which joint, `calibration_id` of a 409, …)."""
        return {k: v for k, v in self.problem.items() if k not in {"type", "title", "status", "detail", "instance"}}


class JobFailed(ApiError):
    """A job (`?async=true`) ended `failed`: its problem is what the synchronous request would have answered."""

    def __init__(self, job: dict[str, Any]) -> None:
        self.job = job
        super().__init__(dict(job.get("error") or {"status": 0, "title": "Job failed", "detail": f"job {job['id']}"}))


class JobCancelled(Exception):
    """A job ended `cancelled` (DELETE /v1/jobs/{id}, from this client or another): nothing of it was written."""

    def __init__(self, job: dict[str, Any]) -> None:
        self.job = job
        super().__init__(f"job {job['id']} was cancelled")


class ServiceUnreachable(Exception):
    """No answer: the connection was refused or timed out, or the name did not resolve."""

    def __init__(self, url: str, reason: object) -> None:
        self.url, self.reason = url, reason
        super().__init__(f"{url} is unreachable: {reason}")


class CampaignFileError(ValueError):
    """A records file the client reads itself (validations take JSON only) lacks a column or holds a non-number."""
