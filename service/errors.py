"""The service's own errors (not the mathematics'): each names what went wrong and carries JSON-safe data.

Tree (the domain's `models.errors.CalibrationError` is the other root `service.problems` renders):

    ServiceError
    ├── BadRequest            400  a body the service cannot parse (CSV that does not follow the header)
    ├── Unauthorized          401  missing or wrong API key
    ├── NotFound              404  an unknown id
    ├── PayloadTooLarge       413  a body over the configured limit
    ├── UnsupportedMediaType  415  neither JSON nor CSV
    ├── JobFinished           409  DELETE of a job that already ended
    ├── QueueFull             429  the job queue is at its bound (with Retry-After)
    ├── Interrupted           503  a job whose worker stopped with the service
    └── NotReady              503  the database does not answer

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


class Unauthorized(ServiceError):
    pass


class NotFound(ServiceError):
    def __init__(self, detail: str, *, resource: str, id: str | None = None) -> None:
        super().__init__(detail, resource=resource, **({} if id is None else {"id": id}))


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
