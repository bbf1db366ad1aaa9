"""Every response of the API tests checked against the OpenAPI document's schema for its operation and status.

Unknown keys are refused everywhere, even where a schema forgot to say so: each object schema with declared
properties and no `additionalProperties` is closed before validating. (The RFC 9457 problem document declares
its extension members open, and stays so.) A response whose status or media type the operation does not
declare fails too.
"""

from __future__ import annotations

import copy
import functools
import json
import re
import threading
from typing import Any

import httpx
import jsonschema_rs
from fastapi import FastAPI
from fastapi.testclient import TestClient

from service.openapi_dump import SNAPSHOT


def _closed(schema: Any) -> Any:
    if isinstance(schema, dict):
        out = {k: _closed(v) for k, v in schema.items()}
        if out.get("type") == "object" and "properties" in out and "additionalProperties" not in out:
            out["additionalProperties"] = False
        return out
    if isinstance(schema, list):
        return [_closed(v) for v in schema]
    return schema


class CompiledContract:
    """An OpenAPI document ready to check against: its object schemas closed, its paths as patterns, and a
    validator per (operation, status, media type) built on first use. Closing and compiling cost ~50 ms; the
    committed document's is made once per process (`committed`) and shared by every test client."""

    def __init__(self, document: dict[str, Any]) -> None:
        self.document = copy.deepcopy(document)
        self.components = _closed(self.document.get("components", {}))
        # Static segments first, so /v1/robots/x/parameters never matches a more general template.
        paths = sorted(self.document["paths"], key=lambda p: (p.count("{"), -len(p)))
        self.paths = [(re.compile("^" + re.sub(r"\{[^/]+\}", "[^/]+", p) + "$"), p) for p in paths]
        self._validators: dict[tuple[str, str, str, str], Any] = {}
        self._lock = threading.Lock()  # test clients of one process may check from several threads

    def operation(self, method: str, path: str) -> tuple[str, dict[str, Any] | None]:
        for pattern, template in self.paths:
            if pattern.match(path):
                return template, self.document["paths"][template].get(method.lower())
        return path, None

    def validator(self, key: tuple[str, str, str, str], schema: dict[str, Any]) -> Any:
        with self._lock:
            found = self._validators.get(key)
            if found is None:
                found = jsonschema_rs.validator_for({**_closed(schema), "components": self.components})
                self._validators[key] = found
            return found


class ContractChecker:
    """Checks responses against one contract and counts them (a test asserts its client checked something)."""

    def __init__(self, document: dict[str, Any] | CompiledContract) -> None:
        self.contract = document if isinstance(document, CompiledContract) else CompiledContract(document)
        self.document = self.contract.document
        self.checked = 0

    def operation(self, method: str, path: str) -> tuple[str, dict[str, Any] | None]:
        return self.contract.operation(method, path)

    def check(self, method: str, path: str, status: int, content_type: str, body: bytes) -> None:
        template, operation = self.operation(method, path)
        if operation is None:
            if path.startswith("/v1"):  # an unknown /v1 path answers a problem document
                assert content_type == "application/problem+json", (path, status, content_type)
            return  # /metrics, /docs, /openapi.json: not part of the contract
        declared = operation["responses"].get(str(status))
        assert declared is not None, f"{method} {path} answered {status}, which its operation does not declare"
        media = content_type.split(";", maxsplit=1)[0].strip()
        if status == 204:
            assert not body, f"{method} {path}: 204 with a body"
            return
        content = declared.get("content", {})
        assert media in content, f"{method} {path} {status}: {media} not declared (declared: {sorted(content)})"
        if not media.endswith("json"):
            return
        schema = content[media].get("schema", {})
        assert schema, f"{method} {path} {status}: the response schema is empty, so it promises nothing"
        found = self.contract.validator((method, template, str(status), media), schema).iter_errors(json.loads(body))
        errors = [f"{'/'.join(map(str, e.instance_path))}: {e.message}" for e in found]
        assert not errors, f"{method} {path} {status} does not match its schema: {errors[:5]}"
        self.checked += 1


@functools.cache
def committed() -> CompiledContract:
    """The committed contract, compiled once per process."""
    return CompiledContract(committed_contract())


def committed_contract() -> dict[str, Any]:
    """The published document, `service/openapi.json` (test_contract.py fails when the app drifts from it).
    Reading it takes milliseconds; FastAPI's `app.openapi()` builds it in ~1 s, per app."""
    document: dict[str, Any] = json.loads(SNAPSHOT.read_text())
    return document


class ContractClient(TestClient):
    """A TestClient that checks every response it receives against an OpenAPI document: the app's own (built
    from its routes: for an app with routes of its own), or the given one (the committed contract)."""

    def __init__(self, app: FastAPI, document: dict[str, Any] | CompiledContract | None = None, **kwargs: Any) -> None:
        super().__init__(app, **kwargs)
        self.contract = ContractChecker(app.openapi() if document is None else document)

    def request(self, method: str, url: httpx.URL | str, **kwargs: Any) -> httpx.Response:
        response: httpx.Response = super().request(method, url, **kwargs)  # starlette 1.x types it Any
        self.contract.check(
            method.upper(),
            response.request.url.path,
            response.status_code,
            response.headers.get("content-type", ""),
            response.content,
        )
        return response
