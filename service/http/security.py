"""API keys with a name and a scope, stored as hashes (the scope each route needs: `service.http.operations`).

Scopes are ordered: `read` < `write` < `admin`. A key of a scope may do everything the scopes below it may.

Configuration (`Settings`; the first two may be combined):

- `IWR_API_KEYS_FILE`: a JSON file, a list of `{"name": ..., "scope": "read"|"write"|"admin", "sha256": <hex>}`;
  the file holds hashes only (`python -m service.http.security KEY` prints a key's hash).
- `IWR_API_KEYS`: comma-separated entries, each `name:scope:sha256hex`, or a bare key as before this module
  existed: a bare key keeps working, as a `write` key named `key-<first 8 hex digits of its hash>` (everything it
  could do before but deleting robots and restoring versions, which are `admin` now). Only its hash is kept.

No key configured at all: no authentication (development), and `request.state.actor` is `anonymous`.

Keys are compared by their SHA-256 with `hmac.compare_digest` against every configured hash, so the time taken
tells neither which key nor which prefix matched. A key is high-entropy by contract (`secrets.token_urlsafe(32)`),
so a fast hash is the right one here: a password hash would add ~100 ms to every request for nothing.
"""

from __future__ import annotations

import enum
import hashlib
import hmac
import json
import re
import sys
from dataclasses import dataclass
from pathlib import Path

from fastapi import Request
from starlette.types import ASGIApp, Receive, Send
from starlette.types import Scope as AsgiScope

from service.errors import Forbidden, ServiceError, Unauthorized
from service.http import problems


class Scope(enum.IntEnum):
    read = 1
    write = 2
    admin = 3


@dataclass(frozen=True)
class ApiKey:
    name: str
    scope: Scope
    sha256: str  # hex digest of the key


ANONYMOUS = "anonymous"
_HEX64 = re.compile(r"^[0-9a-f]{64}$")
_NAME = re.compile(r"^[A-Za-z0-9_.@-]{1,100}$")  # fits audit_events.actor (String(100)); no control characters


def digest(key: str) -> str:
    return hashlib.sha256(key.encode("utf-8")).hexdigest()


def _key(name: str, scope: str, sha256: str, where: str) -> ApiKey:
    if not _NAME.match(name):
        raise ValueError(f"{where}: key name {name!r} must be 1-100 of A-Z a-z 0-9 _ . @ -")
    if scope not in Scope.__members__:
        raise ValueError(f"{where}: scope {scope!r} of key {name!r} is not one of {list(Scope.__members__)}")
    if not _HEX64.match(sha256.lower()):
        raise ValueError(f"{where}: key {name!r} needs a SHA-256 as 64 hex digits")
    return ApiKey(name, Scope[scope], sha256.lower())


def parse_keys(env: str, file: str | None) -> tuple[ApiKey, ...]:
    """Every configured key; a wrong entry stops the start-up with a message naming it (never the key)."""
    keys: list[ApiKey] = []
    if file:
        entries = json.loads(Path(file).read_text())
        if not isinstance(entries, list):
            raise ValueError(f"{file}: a JSON list of {{name, scope, sha256}} objects is expected")
        for i, entry in enumerate(entries):
            if not isinstance(entry, dict) or set(entry) != {"name", "scope", "sha256"}:
                raise ValueError(f"{file}: entry {i} must have exactly name, scope and sha256")
            keys.append(_key(str(entry["name"]), str(entry["scope"]), str(entry["sha256"]), f"{file} entry {i}"))
    for i, raw in enumerate(e.strip() for e in env.split(",")):
        if not raw:
            continue
        parts = raw.split(":")
        if len(parts) == 3 and _HEX64.match(parts[2].lower()):
            keys.append(_key(parts[0], parts[1], parts[2], f"IWR_API_KEYS entry {i}"))
        else:  # a bare key, as before scopes existed
            hashed = digest(raw)
            keys.append(ApiKey(f"key-{hashed[:8]}", Scope.write, hashed))
    names = [k.name for k in keys]
    if len(names) != len(set(names)):
        raise ValueError(f"API key names must be unique: {sorted(n for n in set(names) if names.count(n) > 1)}")
    return tuple(keys)


# ------------------------------------------------------------------ the scope of every route
OTHER_SCOPES: dict[str, Scope] = {"/metrics": Scope.read, "/docs": Scope.read, "/openapi.json": Scope.read}
"""Outside /v1, guarded only when the settings say so (`metrics_public`, `docs_public` false)."""


def authenticate(keys: tuple[ApiKey, ...], given: str | None) -> ApiKey:
    if not given:
        raise Unauthorized("send a valid API key in the X-API-Key header")
    hashed = digest(given).encode()
    found: ApiKey | None = None
    for key in keys:  # every hash compared, whichever matches
        if hmac.compare_digest(hashed, key.sha256.encode()):
            found = key
    if found is None:
        raise Unauthorized("send a valid API key in the X-API-Key header")
    return found


def authorize(request: Request, needed: Scope) -> None:
    """Sets `request.state.actor` to the key's name (the audit trail records it; never the key)."""
    keys: tuple[ApiKey, ...] = request.app.state.api_keys
    if not keys:
        request.state.actor = ANONYMOUS
        return
    key = authenticate(keys, request.headers.get("x-api-key"))
    request.state.actor = key.name
    if key.scope < needed:
        raise Forbidden(
            f"key {key.name!r} has scope {key.scope.name!r}; this operation needs {needed.name!r}",
            scope=key.scope.name,
            required=needed.name,
        )


class GuardedPaths:
    """/metrics, /docs and /openapi.json behind a `read` key when the settings say so (and keys exist)."""

    def __init__(self, app: ASGIApp, *, metrics: bool, docs: bool) -> None:
        self.app = app
        self.paths = {p for p, on in (("/metrics", metrics), ("/docs", docs), ("/openapi.json", docs)) if on}

    async def __call__(self, scope: AsgiScope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope.get("path") in self.paths:
            try:
                authorize(Request(scope), OTHER_SCOPES[scope["path"]])
            except ServiceError as exc:
                await problems.response(problems.to_problem(exc))(scope, receive, send)
                return
        await self.app(scope, receive, send)


if __name__ == "__main__":  # python -m service.http.security KEY: the hash to put in the keys file
    print(digest(sys.argv[1]))
