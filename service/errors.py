"""The service's own errors (not the mathematics'): each names what went wrong and carries JSON-safe data.

Every class declares its fields (keyword-only, typed), as `models.errors` does, so a misspelt member is a type
error where it is raised; `.data` is the dictionary of those that have a value, the problem document's
extension members, in declaration order. Tree (the domain's `models.errors.CalibrationError` is the other root
`service.problems` renders):

    ServiceError()
    ├── BadRequest(line, column, record)               400  a body the service cannot parse
    ├── CalibrationFailed(calibration_id, diagnoses)   422  the fit failed (stored, never applied)
    ├── Unauthorized()                                 401  missing or wrong API key
    ├── Forbidden(scope, required)                     403  a key whose scope does not cover the operation
    ├── NotFound(resource, id)                         404  an unknown id
    ├── NotAcceptable(offered)                         406  no representation the Accept header allows
    ├── PreconditionFailed(current)                    412  If-Match names a revision no longer current
    ├── Conflict(id, calibration_id, start_version, current_version, retry_after)
    │                                                  409  another request got there first
    ├── RequestTimeout()                               408  a body that did not arrive in time
    ├── PayloadTooLarge(limit)                         413  a body over the configured limit
    ├── UnsupportedMediaType(content_type)             415  neither JSON nor CSV
    ├── IdempotencyKeyReused()                         422  an Idempotency-Key sent again with another request
    ├── WorkTooLarge(estimated_s, estimated_bytes, limit_s, limit_bytes, use_async)
    │                                                  422  more work than a synchronous request (or any job)
    ├── Overloaded(retry_after)                        503  every compute slot busy
    ├── ClientGone()                                   503  the client left before its computation started
    ├── JobFinished(job_status)                        409  DELETE of a job that already ended
    ├── QueueFull(limit, retry_after)                  429  the job queue is at its bound
    ├── Interrupted()                                  503  a job whose worker stopped with the service
    └── NotReady()                                     503  the database does not answer
        └── DatabaseUnavailable(retry_after)           …mid-request: a lost connection, a locked or full SQLite

A `retry_after` (seconds) becomes the response's Retry-After header too. Persistence raises `NotFound` without
knowing HTTP; `service.problems` alone maps these classes to status, type and title.
"""

from __future__ import annotations

from typing import Any, ClassVar


class ServiceError(Exception):
    """Root of the service's errors."""

    fields: ClassVar[tuple[str, ...]] = ()
    """The names of the keyword-only fields of the class, in `.data` order."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail

    @property
    def data(self) -> dict[str, Any]:
        """The fields that have a value: a field left at None (it does not apply) is absent rather than null.

        A property over attributes, not a stored dictionary, so an error that crosses from a compute process
        (which copies the instance's attributes) keeps its members."""
        values = ((name, getattr(self, name)) for name in self.fields)
        return {name: value for name, value in values if value is not None}


class BadRequest(ServiceError):
    """`line` and `column` (1-based) locate the mistake in a file; `record` (0-based) in a campaign."""

    fields: ClassVar[tuple[str, ...]] = ("line", "column", "record")

    def __init__(
        self, detail: str, *, line: int | None = None, column: int | None = None, record: int | None = None
    ) -> None:
        super().__init__(detail)
        self.line = line
        self.column = column
        self.record = record


class CalibrationFailed(ServiceError):
    """A calibration whose fit failed: stored for the record (`calibration_id`), never applied."""

    fields: ClassVar[tuple[str, ...]] = ("calibration_id", "diagnoses")

    def __init__(self, detail: str, *, calibration_id: str, diagnoses: list[dict[str, Any]]) -> None:
        super().__init__(detail)
        self.calibration_id = calibration_id
        self.diagnoses = diagnoses


class Unauthorized(ServiceError):
    pass


class Forbidden(ServiceError):
    """`scope`: the key's; `required`: the operation's."""

    fields: ClassVar[tuple[str, ...]] = ("scope", "required")

    def __init__(self, detail: str, *, scope: str, required: str) -> None:
        super().__init__(detail)
        self.scope = scope
        self.required = required


class NotFound(ServiceError):
    """`id` is left out where the resource has none of its own (a parameter version, a path)."""

    fields: ClassVar[tuple[str, ...]] = ("resource", "id")

    def __init__(self, detail: str, *, resource: str, id: str | None = None) -> None:
        super().__init__(detail)
        self.resource = resource
        self.id = id


class NotAcceptable(ServiceError):
    fields: ClassVar[tuple[str, ...]] = ("offered",)

    def __init__(self, detail: str, *, offered: list[str]) -> None:
        super().__init__(detail)
        self.offered = offered


class PreconditionFailed(ServiceError):
    """`current` is the ETag the resource has now, so the client can re-read and decide."""

    fields: ClassVar[tuple[str, ...]] = ("current",)

    def __init__(self, detail: str, *, current: str) -> None:
        super().__init__(detail)
        self.current = current


class Conflict(ServiceError):
    """One class for three races, each with its own members: a robot name taken (`id`, the robot holding it),
    a calibration that lost to a newer parameter version (`calibration_id`, `start_version`,
    `current_version`), an Idempotency-Key whose first request still runs (`retry_after`)."""

    fields: ClassVar[tuple[str, ...]] = ("id", "calibration_id", "start_version", "current_version", "retry_after")

    def __init__(
        self,
        detail: str,
        *,
        id: str | None = None,
        calibration_id: str | None = None,
        start_version: int | None = None,
        current_version: int | None = None,
        retry_after: int | None = None,
    ) -> None:
        super().__init__(detail)
        self.id = id
        self.calibration_id = calibration_id
        self.start_version = start_version
        self.current_version = current_version
        self.retry_after = retry_after


class IdempotencyKeyReused(ServiceError):
    pass


class WorkTooLarge(ServiceError):
    """Over the cap of any job, the estimate and the cap in time and memory; over the synchronous budget, the
    time only and whether `?async=true` would take it (`use_async`)."""

    fields: ClassVar[tuple[str, ...]] = ("estimated_s", "estimated_bytes", "limit_s", "limit_bytes", "use_async")

    def __init__(
        self,
        detail: str,
        *,
        estimated_s: float,
        limit_s: float,
        estimated_bytes: int | None = None,
        limit_bytes: int | None = None,
        use_async: bool | None = None,
    ) -> None:
        super().__init__(detail)
        self.estimated_s = estimated_s
        self.estimated_bytes = estimated_bytes
        self.limit_s = limit_s
        self.limit_bytes = limit_bytes
        self.use_async = use_async


class Overloaded(ServiceError):
    fields: ClassVar[tuple[str, ...]] = ("retry_after",)

    def __init__(self, detail: str, *, retry_after: int) -> None:
        super().__init__(detail)
        self.retry_after = retry_after


class ClientGone(ServiceError):
    pass


class RequestTimeout(ServiceError):
    pass


class PayloadTooLarge(ServiceError):
    fields: ClassVar[tuple[str, ...]] = ("limit",)

    def __init__(self, detail: str, *, limit: int) -> None:
        super().__init__(detail)
        self.limit = limit


class UnsupportedMediaType(ServiceError):
    fields: ClassVar[tuple[str, ...]] = ("content_type",)

    def __init__(self, detail: str, *, content_type: str) -> None:
        super().__init__(detail)
        self.content_type = content_type


class JobFinished(ServiceError):
    """`job_status`, not `status`: a problem document's `status` is the HTTP one."""

    fields: ClassVar[tuple[str, ...]] = ("job_status",)

    def __init__(self, detail: str, *, job_status: str) -> None:
        super().__init__(detail)
        self.job_status = job_status


class QueueFull(ServiceError):
    fields: ClassVar[tuple[str, ...]] = ("limit", "retry_after")

    def __init__(self, detail: str, *, limit: int, retry_after: int) -> None:
        super().__init__(detail)
        self.limit = limit
        self.retry_after = retry_after


class Interrupted(ServiceError):
    pass


class NotReady(ServiceError):
    pass


class DatabaseUnavailable(NotReady):
    """The database refused or dropped the connection, or cannot write now (SQLite locked or its disk full):
    a 503 with `retry_after`, never a 500; the next request connects afresh (the pool pings first)."""

    fields: ClassVar[tuple[str, ...]] = ("retry_after",)

    def __init__(self, detail: str, *, retry_after: int) -> None:
        super().__init__(detail)
        self.retry_after = retry_after
