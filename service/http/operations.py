"""Each HTTP operation's policy, declared once, on its route.

An operation says who may call it (`scope`), where its work runs (`runs`), how its work is counted from the raw
bytes before anything is parsed (`precount`, for the bodies that can be large) and which job kind it becomes
with `?async=true` (`job`). The route's endpoint carries it (`@operation(...)`); everything else derives from the
routes: the key check (`service.http.deps.require_api_key`), the byte pre-count (`service.http.guards`), the `x-scope`
of
the published contract (`service.http.openapi`) and the table `tests/service/test_security.py` checks. A route that
declares nothing is refused to every key but `admin` (fail closed).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, TypeVar

import numpy as np
from fastapi import FastAPI
from fastapi.routing import iter_route_contexts
from starlette.routing import Match
from starlette.types import Scope as AsgiScope

from service.compute import limits
from service.http.security import Scope
from service.schemas.jobs import JobKind

F = TypeVar("F", bound=Callable[..., Any])
_ATTRIBUTE = "__operation__"


class Runs(StrEnum):
    """Where an operation's work runs: what it may cost the event loop and the compute slots."""

    LOOP = "loop"
    """On the event loop: no database, no numerics (health, job cancellation bookkeeping is a thread)."""
    THREAD = "thread"
    """In the threadpool: database reads and writes, small checks."""
    COMPUTE = "compute"
    """In a compute process behind the gate (`service.compute.limits.ComputeGate`): the numerics."""


@dataclass(frozen=True)
class Precount:
    """The work of a body counted in its raw bytes (C speed, ~1 ms per MB): over the synchronous budget it is
    refused before anything is parsed, the key check included."""

    count: Callable[[bytes], int]
    estimate: Callable[..., limits.Estimate]
    count_table: Callable[[bytes], int] | None = None
    """The same work counted in a CSV or multipart body (None: the operation's files are not counted)."""
    sized: bool = False
    """The estimate also takes the body's size in bytes: reading a program costs by its text, not only by the
    targets it holds (a 10 MB line with none took 20 s and 3.4 GB)."""

    def of(self, body: bytes) -> limits.Estimate:
        n = self.count(body)
        return self.estimate(n, len(body)) if self.sized else self.estimate(n)


@dataclass(frozen=True)
class Operation:
    scope: Scope
    """The least scope of an API key that may call it: computations that store nothing are `read`, whatever
    creates a record `write`, deleting and restoring `admin`."""
    runs: Runs = Runs.THREAD
    precount: Precount | None = None
    job: JobKind | None = None
    """The job kind it becomes with `?async=true` (None: it has no async form)."""
    tables: bool = False
    """It reads CSV files (`text/csv` or `multipart/form-data`): their lines, cells and fields per line are bounded
    before they are parsed (`service.http.guards.table_shape`, limits in `service.compute.limits`)."""


def _joint_vectors(body: bytes) -> int:
    # `{"joints": [[...], [...], ...]}`: one bracket per vector and one for the list (numbers hold none)
    return body.count(b"[") - 1


def _targets(body: bytes) -> int:
    # Every target has a position; in valid JSON `"position"` before a colon is a key, never text.
    return len(_POSITION_KEY.findall(body))


def _records(body: bytes) -> int:
    # Every measurement record has joints; `"joints"` before a colon is a key, never text (1.6 MB: ~3 ms).
    return len(_JOINTS_KEY.findall(body))


def text_lines(body: bytes) -> int:
    """Lines of a text body, as `bytes.splitlines` and the CSV reader break them (LF, CRLF or a lone CR: a file of
    CR line ends is one line to `wc -l`), counted at C speed (a 10 MB body ~5 ms)."""
    breaks = body.count(b"\n") + body.count(b"\r") - body.count(b"\r\n")
    return breaks + (0 if not body or body.endswith((b"\n", b"\r")) else 1)  # the text after the last break


def _table_records(body: bytes) -> int:
    # An upper count of a campaign file's records: a CSV's lines after the header; in a multipart body of a joint
    # file and a point file each record is a line of both (records <= min(a, b) <= (a + b) / 2); of a `records`
    # file, the body's lines. Blank and comment lines count too: an estimate that errs towards a job.
    lines = text_lines(body)
    return lines // 2 if b'name="joints"' in body else max(lines - 1, 0)


def _evaluations(body: bytes) -> int:
    # Records × versions: each record is compared with each version. `"versions"` before a colon is a key (a
    # list of integers: its commas count its items); absent, one version, the current.
    records = _records(body)
    found = _VERSIONS_KEY.search(body)
    versions = found.group(1).count(b",") + 1 if found and found.group(1).strip() else 1
    return records * versions


def _candidates(body: bytes) -> int:
    # The items of the top-level `"candidates"` array that are arrays or objects (a joint vector, a reference
    # candidate): its brackets, strings removed, and the openings one level inside it (C speed: 15 MB ~0.1 s).
    # A key is never text: inside a JSON string its quotes are escaped.
    found = _CANDIDATES_KEY.search(body)
    if found is None:
        return 0
    brackets = _STRING.sub(b"", body[found.end() - 1 :]).translate(None, _NOT_BRACKETS)
    steps = _STEP[np.frombuffer(brackets, dtype=np.uint8)]
    depth = np.cumsum(steps, dtype=np.int64)
    closed = np.flatnonzero(depth == 0)  # where the array ends (malformed: to the body's end, the parser's to refuse)
    end = int(closed[0]) if closed.size else depth.size
    return int(np.count_nonzero((steps[:end] == 1) & (depth[:end] == 2)))


def program_targets(body: bytes) -> int:
    """An upper count of a robot program's targets in its bytes, JSON or the text itself, whatever its format:
    KRL aggregates that open with X (`{X`, `{E6POS: X`), RAPID's nested aggregates (`[[`: every robtarget, and
    the few tool and work object data), URScript pose literals (`p[`); a CSV's lines where none of those is
    found (a newline, or `\\n` inside a JSON string)."""
    marked = len(_KRL_POSE.findall(body)) + body.count(b"[[") + body.count(b"p[")
    return marked if marked else max(body.count(b"\n"), body.count(b"\\n"))


_KRL_POSE = re.compile(rb"\{\s*(?:[A-Za-z0-9_]+\s*:\s*)?[Xx]\s")
_POSITION_KEY = re.compile(rb'"position"\s*:')
_JOINTS_KEY = re.compile(rb'"joints"\s*:')
_CANDIDATES_KEY = re.compile(rb'"candidates"\s*:\s*\[')
_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"')  # a JSON string, escapes included (as service.http.guards reads it)
_NOT_BRACKETS = bytes(c for c in range(256) if c not in b"[]{}")
_STEP = np.zeros(256, dtype=np.int8)
_STEP[list(b"[{")], _STEP[list(b"]}")] = 1, -1
_VERSIONS_KEY = re.compile(rb'"versions"\s*:\s*\[([^\]]*)\]')

# Measured: the schema's 100 000 joint vectors, 7 MB, took 0.8 s of loop to parse and validate, only to be
# refused; a 6 000-record calibration's key check waited up to 2.9 s for the parse process behind other large
# bodies, only to be refused. Counted in the bytes, both are refused in milliseconds.
FORWARD_KINEMATICS = Precount(_joint_vectors, limits.forward_kinematics)
INVERSE_KINEMATICS = Precount(_targets, limits.inverse_kinematics)
CALIBRATION = Precount(_records, limits.calibration, count_table=_table_records)
PROGRAM_COMPENSATION = Precount(program_targets, limits.program_compensation, sized=True)
# A validation's or a check's file is counted as a calibration's (its records from its lines); the versions a
# validation's query adds are counted once the file is read.
VALIDATION = Precount(_evaluations, limits.validation, count_table=_table_records)
QUICK_CHECK = Precount(_records, limits.quick_check, count_table=_table_records)
POSE_DESIGN = Precount(_candidates, limits.pose_design_at_least)


def operation(
    scope: Scope,
    *,
    runs: Runs = Runs.THREAD,
    precount: Precount | None = None,
    job: JobKind | None = None,
    tables: bool = False,
) -> Callable[[F], F]:
    """Declares the policy of the endpoint it decorates (put it under the router's decorator)."""
    declared = Operation(scope, runs, precount, job, tables)

    def mark(endpoint: F) -> F:
        setattr(endpoint, _ATTRIBUTE, declared)
        return endpoint

    return mark


def of_route(route: object) -> Operation | None:
    """The operation a route's endpoint declares (None: nothing declared)."""
    found = getattr(getattr(route, "endpoint", None), _ATTRIBUTE, None)
    return found if isinstance(found, Operation) else None


def required_scope(route: object, *, as_job: bool = False) -> Scope:
    """The scope a route needs: its declaration's, or `admin` for a route that declares none. Sent as a job
    (`as_job`), at least `write`: a job is a record the service stores (its row, its answer), so a computation a
    read key may ask for synchronously (a program's compensation) needs a write key to be queued."""
    found = of_route(route)
    if found is None:
        return Scope.admin
    return job_scope(found) if as_job and found.job is not None else found.scope


def job_scope(found: Operation) -> Scope:
    """The scope of an operation's `?async=true` form."""
    return max(found.scope, Scope.write)


def _v1_routes(app: FastAPI) -> Iterator[tuple[str, str, object]]:
    for route in iter_route_contexts(app.routes):
        path = str(getattr(route, "path", ""))
        if path.startswith("/v1"):
            for method in getattr(route, "methods", None) or ():
                if method != "HEAD":
                    yield method, path, route


def table(app: FastAPI) -> dict[tuple[str, str], Operation | None]:
    """(method, path template) -> the declared operation of every /v1 route, in or out of the schema."""
    return {(method, path): of_route(route) for method, path, route in sorted(_v1_routes(app), key=lambda r: r[:2])}


def matching(scope: AsgiScope) -> Operation | None:
    """The operation of the route a request will reach, for the middleware that runs before routing (the
    included routers' routes, in their order)."""
    app = scope.get("app")
    for route in iter_route_contexts(getattr(app, "routes", ())):
        match, _ = route.matches(scope)
        if match is Match.FULL:
            return of_route(route)
    return None
