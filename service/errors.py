"""The service's own errors (not the mathematics'): each names what went wrong and carries JSON-safe data.

Tree (the domain's `models.errors.CalibrationError` is the other root `service.problems` renders):

    ServiceError
    ├── BadRequest            400  a body the service cannot parse (CSV that does not follow the header)
    ├── CalibrationFailed     422  the fit failed (stored, never applied): its id, the reason, the diagnoses
    ├── Unauthorized          401  missing or wrong API key
    ├── Forbidden             403  a key whose scope does not cover the operation
    ├── NotFound              404  an unknown id
    ├── NotAcceptable         406  no representation the Accept header allows
    ├── PreconditionFailed    412  If-Match names a revision that is no longer current
    ├── Conflict              409  another request got there first (a newer parameter version, a key in use)
    ├── RequestTimeout        408  a body that did not arrive in time
    ├── PayloadTooLarge       413  a body over the configured limit
    ├── UnsupportedMediaType  415  neither JSON nor CSV
    ├── IdempotencyKeyReused  422  an Idempotency-Key sent again with another request
    ├── WorkTooLarge          422  more work than a synchronous request (or any job) may ask for
    ├── Overloaded            503  every compute slot busy (with Retry-After)
    ├── ClientGone            503  the client left before its computation started (nobody reads this)
    ├── JobFinished           409  DELETE of a job that already ended
    ├── QueueFull             429  the job queue is at its bound (with Retry-After)
    ├── Interrupted           503  a job whose worker stopped with the service
    └── NotReady              503  the database does not answer
        └── DatabaseUnavailable     …mid-request: a lost connection, a locked or full SQLite (with Retry-After)

Persistence raises `NotFound` without knowing HTTP; `service.problems` alone maps these classes to status,
type and title.
"""

from __future__ import annotations

from typing import Any


class ServiceError(Exception):
    """Root of the service's errors; `data` becomes the problem document's extension members."""

    def __init__(self, detail: str, **data: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.data: dict[str, Any] = data


class BadRequest(ServiceError):
    """`line` and `column` (1-based) locate the mistake in a file; `record` (0-based) in a campaign."""

    def __init__(
        self, detail: str, *, line: int | None = None, column: int | None = None, record: int | None = None
    ) -> None:
        data = {k: v for k, v in (("line", line), ("column", column), ("record", record)) if v is not None}
        super().__init__(detail, **data)


class CalibrationFailed(ServiceError):
    """A calibration whose fit failed: stored for the record (`calibration_id`), never applied."""

    def __init__(self, detail: str, *, calibration_id: str, diagnoses: list[dict[str, Any]]) -> None:
        super().__init__(detail, calibration_id=calibration_id, diagnoses=diagnoses)


class Unauthorized(ServiceError):
    pass


class Forbidden(ServiceError):
    """`scope`: the key's; `required`: the operation's."""


class NotFound(ServiceError):
    def __init__(self, detail: str, *, resource: str, id: str | None = None) -> None:
        super().__init__(detail, resource=resource, **({} if id is None else {"id": id}))


class NotAcceptable(ServiceError):
    def __init__(self, detail: str, *, offered: list[str]) -> None:
        super().__init__(detail, offered=offered)


class PreconditionFailed(ServiceError):
    """`current` is the ETag the resource has now, so the client can re-read and decide."""

    def __init__(self, detail: str, *, current: str) -> None:
        super().__init__(detail, current=current)


class Conflict(ServiceError):
    pass


class IdempotencyKeyReused(ServiceError):
    pass


class WorkTooLarge(ServiceError):
    pass


class Overloaded(ServiceError):
    pass


class ClientGone(ServiceError):
    pass


class RequestTimeout(ServiceError):
    pass


class PayloadTooLarge(ServiceError):
    def __init__(self, detail: str, *, limit: int) -> None:
        super().__init__(detail, limit=limit)


class UnsupportedMediaType(ServiceError):
    def __init__(self, detail: str, *, content_type: str) -> None:
        super().__init__(detail, content_type=content_type)


class JobFinished(ServiceError):
    def __init__(self, detail: str, *, status: str) -> None:
        super().__init__(detail, job_status=status)


class QueueFull(ServiceError):
    """`retry_after` (seconds) becomes the response's Retry-After header too."""

    def __init__(self, detail: str, *, limit: int, retry_after: int) -> None:
        super().__init__(detail, limit=limit, retry_after=retry_after)


class Interrupted(ServiceError):
    pass


class NotReady(ServiceError):
    pass


class DatabaseUnavailable(NotReady):
    """The database refused or dropped the connection, or cannot write now (SQLite locked or its disk full):
    a 503 with `retry_after`, never a 500; the next request connects afresh (the pool pings first)."""

    def __init__(self, detail: str, *, retry_after: int) -> None:
        super().__init__(detail, retry_after=retry_after)
