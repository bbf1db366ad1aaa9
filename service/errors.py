"""The service's own errors (not the mathematics'): each names what went wrong and carries JSON-safe data.

Every class declares its fields as annotated attributes (`declared`: keyword-only, typed), so a misspelt
member is a type error where it is raised; `.data` is the dictionary of those that have a value, the problem
document's extension members, in declaration order. Tree (the domain's `models.errors.CalibrationError` is the
other root `service.http.problems` renders):

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
    ├── ParseTimeout(limit_s)                          422  a body not read within the parse deadline
    ├── Overloaded(retry_after)                        503  every compute slot busy
    ├── ClientGone()                                   503  the client left before its computation started
    ├── JobFinished(job_status)                        409  DELETE of a job that already ended
    ├── QueueFull(limit, retry_after)                  429  the job queue is at its bound
    ├── Interrupted()                                  503  a job whose worker stopped with the service
    └── NotReady()                                     503  the database does not answer
        └── DatabaseUnavailable(retry_after)           …mid-request: a lost connection, a locked or full SQLite

A `retry_after` (seconds) becomes the response's Retry-After header too. Persistence raises `NotFound` without
knowing HTTP; `service.http.problems` alone maps these classes to status, type and title.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, TypeVar, dataclass_transform

E = TypeVar("E", bound="ServiceError")


@dataclasses.dataclass(eq=False)
class ServiceError(Exception):
    """Root of the service's errors."""

    detail: str
    fields: ClassVar[tuple[str, ...]] = ()
    """The names of the keyword-only fields of the class, in `.data` order (set by `declared`)."""

    def __post_init__(self) -> None:
        super().__init__(self.detail)

    @property
    def data(self) -> dict[str, Any]:
        """The fields that have a value: a field left at None (it does not apply) is absent rather than null.

        A property over attributes, not a stored dictionary, so an error that crosses from a compute process
        (which copies the instance's attributes) keeps its members."""
        values = ((name, getattr(self, name)) for name in self.fields)
        return {name: value for name, value in values if value is not None}


@dataclass_transform(kw_only_default=True, eq_default=False)
def declared(cls: type[E]) -> type[E]:
    """An error class whose annotated attributes are its keyword-only fields (a dataclass: a misspelt or missing
    member is a type error where it is raised), compared by identity as exceptions are."""
    made = dataclasses.dataclass(eq=False, kw_only=True)(cls)
    made.fields = tuple(f.name for f in dataclasses.fields(made) if f.name != "detail")
    return made


@declared
class BadRequest(ServiceError):
    """`line` and `column` (1-based) locate the mistake in a file; `record` (0-based) in a campaign."""

    line: int | None = None
    column: int | None = None
    record: int | None = None


@declared
class CalibrationFailed(ServiceError):
    """A calibration whose fit failed: stored for the record (`calibration_id`), never applied."""

    calibration_id: str
    diagnoses: list[dict[str, Any]]


@declared
class Unauthorized(ServiceError):
    pass


@declared
class Forbidden(ServiceError):
    """`scope`: the key's; `required`: the operation's."""

    scope: str
    required: str


@declared
class NotFound(ServiceError):
    """`id` is left out where the resource has none of its own (a parameter version, a path)."""

    resource: str
    id: str | None = None


@declared
class NotAcceptable(ServiceError):
    offered: list[str]


@declared
class PreconditionFailed(ServiceError):
    """`current` is the ETag the resource has now, so the client can re-read and decide."""

    current: str


@declared
class Conflict(ServiceError):
    """One class for three races, each with its own members: a robot name taken (`id`, the robot holding it),
    a calibration that lost to a newer parameter version (`calibration_id`, `start_version`,
    `current_version`), an Idempotency-Key whose first request still runs (`retry_after`)."""

    id: str | None = None
    calibration_id: str | None = None
    start_version: int | None = None
    current_version: int | None = None
    retry_after: int | None = None


@declared
class IdempotencyKeyReused(ServiceError):
    pass


@declared
class WorkTooLarge(ServiceError):
    """Over the cap of any job, the estimate and the cap in time and memory; over the synchronous budget, the
    time only and whether `?async=true` would take it (`use_async`)."""

    estimated_s: float
    estimated_bytes: int | None = None
    limit_s: float
    limit_bytes: int | None = None
    use_async: bool | None = None


@declared
class ParseTimeout(ServiceError):
    """A body whose reading passed the parse deadline (`limit_s`): dropped, its parse process replaced."""

    limit_s: float


@declared
class Overloaded(ServiceError):
    retry_after: int


@declared
class ClientGone(ServiceError):
    pass


@declared
class RequestTimeout(ServiceError):
    pass


@declared
class PayloadTooLarge(ServiceError):
    limit: int


@declared
class UnsupportedMediaType(ServiceError):
    content_type: str


@declared
class JobFinished(ServiceError):
    """`job_status`, not `status`: a problem document's `status` is the HTTP one."""

    job_status: str


@declared
class QueueFull(ServiceError):
    limit: int
    retry_after: int


@declared
class Interrupted(ServiceError):
    pass


@declared
class NotReady(ServiceError):
    pass


@declared
class DatabaseUnavailable(NotReady):
    """The database refused or dropped the connection, or cannot write now (SQLite locked or its disk full):
    a 503 with `retry_after`, never a 500; the next request connects afresh (the pool pings first)."""

    retry_after: int
