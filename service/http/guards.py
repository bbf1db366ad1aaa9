"""Request hygiene before any route runs: what no route can answer well by itself.

- A path that differs from a route's only by a trailing slash is a 404 naming the route's path (Starlette's 307
  copied the client's Host header into its Location; the app has `redirect_slashes=False`).
- A path with a NUL character names nothing: every id is a UUID the service made, and PostgreSQL text cannot
  even hold NUL (psycopg raises DataError, which was a 500). Answered 404 here, for every route, present and
  future, before a query is built.
- A body is read within `BODY_TIMEOUT_S` (else 408: a slow client holds no worker for long), and a JSON body
  over `OFFLOOP_BYTES` is parsed and checked off the event loop first (in a compute process, service.compute.pool):
  no object with more keys than `MAX_OBJECT_KEYS` (measured on main: 300 000 unknown keys in 3.5 MB blocked
  the loop 6.9 s and answered 19.7 MB of errors; the issue's 1.3 million keys, 20 s and 86 MB). The largest
  schema object has 9 keys. No JSON body nests deeper than `MAX_DEPTH` (any size; counted in the raw bytes).
- A CSV or multipart body to an operation that reads tables (`Operation.tables`) is bounded in its raw bytes before
  any parser sees it: its records counted from its lines against the work budget (`Precount.count_table`), its
  cells and fields per line against `limits.TABLE_CELLS_MAX` and `limits.TABLE_FIELDS_MAX` (`table_shape`); over
  `INLINE_CHECK_BYTES`, counted in the parse process.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import anyio
import numpy as np
import orjson
from fastapi.exceptions import RequestValidationError
from python_multipart.multipart import MAX_BOUNDARY_LENGTH, parse_options_header
from starlette.routing import Match
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.compute import limits
from service.errors import BadRequest, NotFound, PayloadTooLarge, RequestTimeout, ServiceError
from service.http import operations, problems

BODY_TIMEOUT_S = 30.0
"""A whole request body within this (unless the app gives `IWR_BODY_TIMEOUT_SECONDS`): the largest accepted
body (IWR_MAX_BODY_BYTES, 20 MB) at ~1 MB/s."""
OFFLOOP_BYTES = 64_000
"""JSON bodies above this are parsed in a worker thread first (json.loads: ~85 ns per byte here, so 64 kB is
~5 ms on the loop at most), which also bounds what the validation on the loop meets."""
INLINE_CHECK_BYTES = 1_000_000
"""JSON bodies up to this get their key check on the loop (orjson: ~3 ms a MB here); larger ones in the parse
process, where a 20 MB body's 60 ms to 0.5 s is nobody's wait but its own."""
MAX_OBJECT_KEYS = 64
"""Keys per JSON object; the schemas' largest object has 9."""
MAX_DEPTH = 32
"""Nesting of a JSON body's arrays and objects, at most; the schemas' deepest document has 7 levels (a robot's
structure, stages, links, range). 5 000 levels were a bare 400 "error parsing the body" (the JSON decoder's recursion
limit), not a problem saying what to fix."""
DRAIN_BYTES = 64_000_000
"""A body over the limit is read to its end (and dropped) before the 413, up to this much: a server that answers
and closes while the client still sends makes the kernel reset the connection, and the client never sees the
413 (measured: 1 in 5 chunked 25 MB uploads). Beyond this, or after BODY_TIMEOUT_S, the connection is closed."""


class RequestGuard:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        exc: NotFound | None = None
        if scope["type"] == "http" and "\x00" in scope.get("path", ""):
            exc = NotFound("no resource has a NUL character in its id", resource="path")
        elif scope["type"] == "http" and (canonical := _without_trailing_slash(scope)) is not None:
            exc = NotFound(
                f"no resource at {scope['path']!r}: the service's paths end without a slash; use {canonical!r}",
                resource="path",
            )
        if exc is not None:
            await problems.response(problems.to_problem(exc))(scope, receive, send)
            return
        await self.app(scope, receive, send)


def _without_trailing_slash(scope: Scope) -> str | None:
    """The route's path when the request's only differs by a trailing slash (None otherwise).

    Starlette's answer was a 307 whose Location it built from the client's own Host header, before any key was
    checked: a redirect to wherever the client (or a proxy's confused cache) said. The app no longer redirects
    (`redirect_slashes=False`); this names the canonical path in a 404 problem, no Location at all, so a client
    fixes its URL once instead of following a hop on every call."""
    path: str = scope.get("path", "")
    app = scope.get("app")
    if len(path) < 2 or not path.endswith("/") or app is None:
        return None
    routes = app.router.routes
    if any(route.matches(scope)[0] is not Match.NONE for route in routes):
        return None  # a path that ends with a slash by right (a static mount's folder)
    stripped = {**scope, "path": path.rstrip("/")}
    if any(route.matches(stripped)[0] is not Match.NONE for route in routes):
        return str(stripped["path"])
    return None


def too_many_keys(body: bytes) -> int | None:
    """The key count of the first object found with more than MAX_OBJECT_KEYS keys (None: none has). Malformed
    JSON is left to FastAPI, which answers it (400/422) with its own message. Plain arguments and answer: a
    body over INLINE_CHECK_BYTES is checked in the parse process (service.compute.pool).

    orjson, then a walk of the containers: 3.5 MB of 300 000 unknown keys in 60-165 ms against 280-375 ms
    for `json.loads` with a pairs hook (this machine, idle and loaded). A key repeated in one object counts
    once, as it does for the validation that follows."""
    try:
        data = orjson.loads(body)
    except orjson.JSONDecodeError:
        return None
    containers: list[Any] = [data]
    while containers:
        node = containers.pop()
        if isinstance(node, dict):
            if len(node) > MAX_OBJECT_KEYS:
                return len(node)
            containers.extend(v for v in node.values() if isinstance(v, dict | list))
        elif isinstance(node, list):
            containers.extend(v for v in node if isinstance(v, dict | list))
    return None


_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"')
"""A JSON string, escapes included (unrolled: linear, no backtracking between alternatives)."""
_NOT_BRACKETS = bytes(c for c in range(256) if c not in b"[]{}")
_STEP = np.zeros(256, dtype=np.int8)
_STEP[list(b"[{")], _STEP[list(b"]}")] = 1, -1


def too_deep(body: bytes) -> int | None:
    """The nesting depth of a JSON body when it is over MAX_DEPTH (None: it is not). Linear and C-speed: the
    strings removed, the brackets kept, their running sum's maximum (a 1 MB body ~10 ms here). Brackets that do
    not balance are the decoder's to report; only the depth is counted here."""
    if body.count(b"[") + body.count(b"{") <= MAX_DEPTH:  # the common case, without a copy
        return None
    brackets = _STRING.sub(b"", body).translate(None, _NOT_BRACKETS)
    if len(brackets) <= MAX_DEPTH:
        return None
    depth = int(np.cumsum(_STEP[np.frombuffer(brackets, dtype=np.uint8)], dtype=np.int64).max())
    return depth if depth > MAX_DEPTH else None


def _raise_too_deep(depth: int | None) -> None:
    if depth is not None:
        raise RequestValidationError(
            [{"loc": ("body",), "msg": f"JSON nested {depth} levels deep; at most {MAX_DEPTH} are accepted"}]
        )


def shape_errors(body: bytes) -> tuple[int | None, int | None]:
    """(depth over MAX_DEPTH, keys over MAX_OBJECT_KEYS) of a JSON body, each None when within: the checks a
    large body gets off the loop, in one hop (plain arguments and answer, for the parse process)."""
    depth = too_deep(body)
    return depth, None if depth is not None else too_many_keys(body)


def _raise_too_many(keys: int | None) -> None:
    if keys is not None:
        raise RequestValidationError(
            [{"loc": ("body",), "msg": f"an object with {keys} keys; at most {MAX_OBJECT_KEYS} are accepted"}]
        )


def precheck(scope: Scope, body: bytes) -> None:
    """422 `work-too-large` for a body whose counted work (its operation's `precount`, `service.http.operations`) is
    over the budget, unless it is sent as a job and the operation has one."""
    found = operations.matching(scope)
    if found is None or found.precount is None:
        return
    _admit(scope, found, found.precount.of(body))


def _admit(scope: Scope, found: operations.Operation, estimate: limits.Estimate) -> None:
    can_run_async = found.job is not None
    run_async = can_run_async and b"async=true" in scope.get("query_string", b"").lower()
    budget = scope["app"].state.settings.sync_budget_seconds
    limits.admit(estimate, run_async=run_async, can_run_async=can_run_async, budget_s=budget)


TABLE_TYPES = (b"text/csv", b"multipart/form-data")
_DELIMITERS = (b",", b";", b"\t")


def table_shape(body: bytes) -> str | None:
    """What is over the bounds of a CSV body (or of a multipart body's files), None when nothing is: its cells
    (`limits.TABLE_CELLS_MAX`) and the fields of its widest line (`limits.TABLE_FIELDS_MAX`), counted in the
    bytes before any parsing: `bytes.count` for the cells (C speed, ~10 ms for 20 MB), then one pass over the
    lines long enough to hold too many fields. Delimiters inside quotes count too: an upper count."""
    lines = operations.text_lines(body)
    delimiters = max(body.count(d) for d in _DELIMITERS)
    cells = lines + delimiters
    if cells > limits.TABLE_CELLS_MAX:
        return (
            f"the CSV has up to {cells} cells ({lines} lines); at most {limits.TABLE_CELLS_MAX} are read in one "
            "request: send fewer records at a time"
        )
    for number, line in enumerate(body.splitlines(), start=1):
        if len(line) > limits.TABLE_FIELDS_MAX:  # a shorter line cannot hold more fields than that
            fields = max(line.count(d) for d in _DELIMITERS) + 1
            if fields > limits.TABLE_FIELDS_MAX:
                return (
                    f"line {number} of the CSV has {fields} fields; at most {limits.TABLE_FIELDS_MAX} are read (a "
                    "campaign has tens of columns): leave out the columns the robot does not use"
                )
    return None


def check_boundary(content_type: bytes) -> None:
    """400 naming the header for a multipart boundary the form parser refuses when it starts (over
    `MAX_BOUNDARY_LENGTH`, 256 characters; RFC 2046 allows 70). python_multipart raised its `FormParserError`
    from inside the route, which was a 500."""
    boundary = parse_options_header(content_type)[1].get(b"boundary", b"")
    if len(boundary) > MAX_BOUNDARY_LENGTH:
        raise BadRequest(
            f"the Content-Type header's multipart boundary has {len(boundary)} characters; at most "
            f"{MAX_BOUNDARY_LENGTH} are read (RFC 2046 allows 70)"
        )


def table_counts(body: bytes, count: Callable[[bytes], int] | None) -> tuple[int | None, str | None]:
    """(the records `count` finds, None without one; what `table_shape` refuses, None if nothing): the checks of a
    CSV or multipart body in one hop (plain arguments and answer, for the parse process)."""
    return (None if count is None else count(body)), table_shape(body)


async def precheck_table(scope: Scope, body: bytes) -> None:
    """A CSV or multipart body to an operation that reads tables: its records (`Precount.count_table`) against
    the budget (422 `work-too-large`), then its shape (`table_shape`: a 422 naming the bound), before parsing. Up
    to INLINE_CHECK_BYTES on the loop (~1 ms a MB of counts); a larger body in the parse process, as JSON is
    (20 MB: 0.1-0.2 s of counts and, for half a million short lines, the pass over them)."""
    found = operations.matching(scope)
    if found is None or not found.tables:
        return
    count = found.precount.count_table if found.precount is not None else None
    if len(body) <= INLINE_CHECK_BYTES:
        records, problem = table_counts(body, count)
    else:
        pool = getattr(scope["app"].state, "compute", None)
        records, problem = await (
            pool.call(table_counts, body, count) if pool else anyio.to_thread.run_sync(table_counts, body, count)
        )
    if records is not None and found.precount is not None:
        _admit(scope, found, found.precount.estimate(records))
    if problem is not None:
        raise RequestValidationError([{"loc": ("body",), "msg": problem}])


class BodyGuard:
    """Reads the body with a deadline and the size limit (over it: drained, then 413, declared or chunked alike),
    checks large JSON off the loop, then replays the body to the app."""

    def __init__(self, app: ASGIApp, limit: int, timeout_s: float | None = None) -> None:
        self.app, self.limit, self.timeout_s = app, limit, timeout_s

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] not in ("POST", "PUT", "PATCH"):
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers", [])).get(b"content-length", b"")
        if declared.isdigit() and int(declared) > self.limit:  # BodyLimit refuses it before reading anything
            await self.app(scope, receive, send)
            return
        timeout_s = BODY_TIMEOUT_S if self.timeout_s is None else self.timeout_s
        try:
            with anyio.fail_after(timeout_s):
                body, disconnected, too_large = await _read(receive, self.limit)
            if disconnected:
                return
            if too_large:
                raise PayloadTooLarge(f"the request body exceeds {self.limit} bytes; send less", limit=self.limit)
            content_type = dict(scope.get("headers", [])).get(b"content-type", b"application/json").lower()
            if content_type.startswith(b"multipart/"):
                check_boundary(content_type)
            if content_type.startswith(TABLE_TYPES):
                await precheck_table(scope, body)
            elif b"json" in content_type:
                if len(body) <= OFFLOOP_BYTES:
                    _raise_too_deep(too_deep(body))  # 64 kB at most: ~1 ms on the loop
                else:
                    precheck(scope, body)
                    depth, keys = await _shape_check(scope, body)
                    _raise_too_deep(depth)
                    _raise_too_many(keys)
        except TimeoutError:
            exc: Exception = RequestTimeout(f"the request body did not arrive within {timeout_s:g} s")
            answer = problems.response(problems.to_problem(exc))
            # And closed: the rest of the body, should it come, is not the next request's headers.
            answer.headers["connection"] = "close"
            await answer(scope, receive, send)
            return
        except (ServiceError, RequestValidationError) as exc:  # 413 counted chunk by chunk, 422 too much work
            await problems.response(problems.to_problem(exc))(scope, receive, send)
            return
        await self.app(scope, replaying(body, receive), send)


def replaying(body: bytes, receive: Receive) -> Receive:
    """The `receive` of an app behind a middleware that has read the whole `body`: the body once, as one message,
    then the client's own messages (its disconnect, when it comes)."""
    sent = False

    async def replay() -> Message:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay


async def _shape_check(scope: Scope, body: bytes) -> tuple[int | None, int | None]:
    if len(body) <= INLINE_CHECK_BYTES:
        return shape_errors(body)
    pool = getattr(scope["app"].state, "compute", None) if "app" in scope else None
    return await (pool.call(shape_errors, body) if pool else anyio.to_thread.run_sync(shape_errors, body))


async def _read(receive: Receive, limit: int) -> tuple[bytes, bool, bool]:
    """(body, disconnected, too large); over the limit the rest is read and dropped, up to DRAIN_BYTES."""
    chunks: list[bytes] = []
    seen = 0
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            return b"", True, False
        chunk = message.get("body", b"")
        seen += len(chunk)
        if seen <= limit:
            chunks.append(chunk)
        elif seen > limit + DRAIN_BYTES:
            return b"", False, True
        if not message.get("more_body", False):
            return (b"".join(chunks), False, False) if seen <= limit else (b"", False, True)
