"""Declared JSON bodies over `guards.OFFLOOP_BYTES`, parsed and validated in the parse process, not on the loop.

FastAPI parses a route's declared body with `json.loads` and validates the dicts on the event loop. Measured
(this machine, loaded): forward kinematics of 58 000 joint vectors (11.5 MB, within the work budget) took
0.32 s to parse and 0.40 s more to validate, all of it a stall of every other request (/healthz included);
pydantic's own JSON validation of the same bytes takes 0.18 s, and in the parse process none of it is the loop's.

FastAPI's documented extension point for this is a custom `APIRoute` whose handler gets a custom `Request`
(see "Custom Request and APIRoute class" in FastAPI's docs). `OffloopRoute` gives each request a `Request`
whose `json()`, for a large body, returns the body already validated as the route's model, by
`model_validate_json` in the parse process; FastAPI then validates that instance against the same model, which
returns it as is. Small bodies, other content types and the OpenAPI document are FastAPI's, unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from pydantic import BaseModel, ValidationError

from service.errors import UnsupportedMediaType
from service.http.guards import OFFLOOP_BYTES

M = TypeVar("M", bound=BaseModel)


def request_body(model: type[BaseModel]) -> dict[str, Any]:
    """`openapi_extra` of a route that reads its JSON body itself: the body FastAPI would have declared (the
    model is added to the components by service.http.openapi)."""
    schema = {"$ref": f"#/components/schemas/{model.__name__}"}
    return {"requestBody": {"required": True, "content": {"application/json": {"schema": schema}}}}


async def raw_json_body(request: Request) -> bytes:
    """The body of a route that reads its JSON itself, as FastAPI would refuse it: another media type is a 415,
    an empty body a missing one."""
    kind = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    if not _is_json_type(kind):
        raise UnsupportedMediaType(f"send the body as application/json, not {kind!r}", content_type=kind)
    raw = await request.body()
    if not raw:
        raise RequestValidationError([{"type": "missing", "loc": ("body",), "msg": "Field required"}])
    return raw


def validated(model: type[M], raw: bytes) -> M:
    """`raw` as `model` where it is read (on the loop for a small body), or RequestValidationError."""
    parsed = validate_json(model, raw)
    if isinstance(parsed, list):
        raise RequestValidationError(parsed)
    return parsed


def validate_json(model: type[M], raw: bytes) -> M | list[dict[str, Any]]:
    """`raw` as `model`, or its validation errors located in the body (plain data: runs in the parse process).
    Of each error only what the problem shows (service.http.problems): its `input` may be the whole body."""
    try:
        return model.model_validate_json(raw)
    except ValidationError as exc:
        errors = exc.errors(include_url=False, include_context=False, include_input=False)
        return [{"type": e["type"], "loc": ("body", *e["loc"]), "msg": e["msg"]} for e in errors]


class _ValidatedRequest(Request):
    """A request whose body was read and whose JSON is already the route's model."""

    raw: bytes
    validated: BaseModel

    async def body(self) -> bytes:
        return self.raw

    async def json(self) -> Any:
        return self.validated


class OffloopRoute(APIRoute):
    """A route whose large JSON body is validated off the event loop (module docstring)."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()
        model = self._body_model()

        async def offloop_handler(request: Request) -> Response:
            if model is None or not _is_json(request):
                return await handler(request)
            body = await request.body()
            if len(body) <= OFFLOOP_BYTES:
                return await handler(request)
            pool = getattr(request.app.state, "compute", None)
            parsed = await pool.call(validate_json, model, body) if pool else validate_json(model, body)
            if isinstance(parsed, list):  # raised here, outside FastAPI's body parsing, which would make it a 400
                raise RequestValidationError(parsed)
            validated = _ValidatedRequest(request.scope, request.receive)
            validated.raw = body
            validated.validated = parsed
            return await handler(validated)

        return offloop_handler

    def _body_model(self) -> type[BaseModel] | None:
        # One body parameter that is a model (not embedded among others, not a form): FastAPI then validates the
        # whole body as that model, which is what `validate_json` reproduces.
        field = self.body_field
        if field is None or len(self.dependant.body_params) != 1:
            return None
        annotation = getattr(field.field_info, "annotation", None)
        embedded = getattr(field.field_info, "embed", False)
        if isinstance(annotation, type) and issubclass(annotation, BaseModel) and not embedded:
            return annotation
        return None


def _is_json(request: Request) -> bool:
    return _is_json_type(request.headers.get("content-type", "").split(";")[0].strip().lower())


def _is_json_type(kind: str) -> bool:
    # As FastAPI decides whether to parse a body as JSON: application/json or application/*+json.
    return kind == "application/json" or (kind.startswith("application/") and kind.endswith("+json"))
