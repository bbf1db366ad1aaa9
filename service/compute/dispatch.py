"""Where a computation on a JSON body runs, chosen once for every route that reads its body itself.

Three places, by the size of the work (each measured; see the constants):

- a body over `OFFLOOP_BYTES` travels to a compute process as its bytes and is validated there (as a model it
  would be unpickled in the API process, holding the GIL its loop needs: 20 000 vectors cost 30-55 ms a
  request); its work was already counted and admitted from the bytes (the operation's `precount`);
- a small body is validated on the loop; when the route says the work is tiny (`inline`), it runs right there,
  a hop to another process costing more than the work;
- otherwise its estimate is admitted (`service.compute.limits`) and the validated model goes to a compute process.

The compute process answers JSON bytes (serialised where the result is: a model would be pickled, unpickled
and serialised again, 0.16 s for 1 000 poses on a loaded machine), or the result itself when the route renders
it otherwise (CSV).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from fastapi import Request
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel

from service.compute import limits
from service.http.deps import Compute
from service.http.guards import OFFLOOP_BYTES
from service.http.json_bodies import raw_json_body, validate_json, validated

B = TypeVar("B", bound=BaseModel)


@dataclass(frozen=True)
class BodyComputation(Generic[B]):
    """A use case `run(body=..., **dependencies)` on a JSON body of `schema`, as the metrics name it (`kind`)."""

    kind: str
    schema: type[B]
    run: Callable[..., BaseModel]
    """A module-level function (it is sent to the compute process by reference), returning a pydantic model."""
    estimate: Callable[[B], limits.Estimate]
    inline: Callable[[B], bool] | None = None
    """Whether the work is small enough to run on the loop (None: never)."""


async def computed(
    compute: Compute, what: BodyComputation[B], request: Request, *, as_json: bool = True, **dependencies: Any
) -> Any:
    """The use case's answer for the request's body: JSON bytes, or with `as_json=False` its model."""
    raw = await raw_json_body(request)
    if len(raw) > OFFLOOP_BYTES:
        out = await compute(
            what.kind, _from_bytes, schema=what.schema, run=what.run, raw=raw, as_json=as_json, **dependencies
        )
        if isinstance(out, list):  # the body's validation errors, found in the compute process
            raise RequestValidationError(out)
        return out
    body = validated(what.schema, raw)
    if what.inline is not None and what.inline(body):
        return _answer(what.run(body=body, **dependencies), as_json)
    run = {"run": what.run, "body": body, "as_json": as_json}
    return await compute.admitted(what.estimate(body), what.kind, _from_model, **run, **dependencies)


def _answer(out: BaseModel, as_json: bool) -> Any:
    return bytes(out.__pydantic_serializer__.to_json(out)) if as_json else out


# In the compute process: `run` and `schema` travel by reference (a module-level function, a class), never
# the route's lambdas.
def _from_model(*, run: Callable[..., BaseModel], body: BaseModel, as_json: bool, **dependencies: Any) -> Any:
    return _answer(run(body=body, **dependencies), as_json)


def _from_bytes(
    *, schema: type[BaseModel], run: Callable[..., BaseModel], raw: bytes, as_json: bool, **dependencies: Any
) -> Any:
    body = validate_json(schema, raw)
    if isinstance(body, list):
        return body
    return _answer(run(body=body, **dependencies), as_json)
