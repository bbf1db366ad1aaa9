"""`Idempotency-Key` on POST: a retry of the same request replays the first answer instead of running again.

Per (API key name, Idempotency-Key):
- first request: the key is claimed (a row with no answer yet), the request runs, and its answer (status,
  content type, body) is stored for `IDEMPOTENCY_TTL_S`;
- the same key with the same request (method, path, query, content type, body: one SHA-256) replays that
  answer, marked `Idempotent-Replayed: true`, without computing anything;
- the same key with another request: 422 `idempotency-key-reused`;
- the same key while its first request still runs: 409 with `Retry-After` (the client's retry after a timeout
  lands here until the first one finishes, then gets the replay).

Answers that a retry should not see again are not stored, and the claim is released: 5xx, and refusals that
say "try again" (401, 403, 408, 409, 429). Everything else is the request's answer, 4xx included.

It applies to every POST under /v1 that carries the header: the creating ones (robots, calibrations, pose
designs, jobs through ?async=true) and, harmlessly, the computations that store nothing.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools

import anyio
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service.errors import BadRequest, Conflict, IdempotencyKeyReused, ServiceError, Unauthorized
from service.http import problems, security
from service.http.guards import replaying
from service.persistence import idempotency as store
from service.persistence.database import Database

IDEMPOTENCY_TTL_S = 24 * 3600.0
"""How long a key's answer is replayed: a day covers a client's retries across a night's outage; after it the key
may be used afresh. (Rows are small: the answers are the ones already stored as records.)"""
IN_FLIGHT_S = 600.0
"""A claim whose request never answered (the process died) frees its key after this: well beyond the longest
synchronous request the limits allow (service.compute.limits.SYNC_BUDGET_S)."""
PURGE_EVERY = 1000
"""Expired rows are deleted every this many claims (one indexed DELETE)."""
_NOT_STORED = frozenset({401, 403, 408, 409, 429})
_KEY_CHARS = frozenset(range(0x21, 0x7F))  # visible ASCII; the column is String(200)


def fingerprint(scope: Scope, body: bytes) -> str:
    headers = dict(scope.get("headers", []))
    h = hashlib.sha256()
    for part in (scope["method"].encode(), scope["path"].encode(), scope.get("query_string", b"")):
        h.update(part + b"\0")
    h.update(headers.get(b"content-type", b"").split(b";")[0].strip().lower() + b"\0")
    h.update(body)
    return h.hexdigest()


class Idempotency:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app
        self.claims = itertools.count(1)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        headers = dict(scope.get("headers", [])) if scope["type"] == "http" else {}
        raw_key = headers.get(b"idempotency-key")
        if raw_key is None or scope["method"] != "POST" or not scope["path"].startswith("/v1/"):
            await self.app(scope, receive, send)
            return
        try:
            key = self._key(raw_key)
            actor = self._actor(scope, headers)
            body = await _read_body(receive)
        except _Unauthenticated:
            await self.app(scope, receive, send)  # the route answers 401 itself
            return
        except _Disconnected:
            return
        except ServiceError as exc:
            await problems.response(problems.to_problem(exc))(scope, receive, send)
            return
        db: Database = scope["app"].state.db
        digest = fingerprint(scope, body)
        if next(self.claims) % PURGE_EVERY == 0:
            await anyio.to_thread.run_sync(store.purge_expired, db)
        stored = await anyio.to_thread.run_sync(
            lambda: store.claim(
                db,
                actor=actor,
                key=key,
                method="POST",
                path=scope["path"][:500],
                body_sha256=digest,
                in_flight_s=IN_FLIGHT_S,
            )
        )
        if stored is not None:
            await self._answer_stored(stored, digest, scope, receive, send)
            return
        await self._run_and_store(scope, receive, send, body, db=db, actor=actor, key=key)

    @staticmethod
    def _key(raw: bytes) -> str:
        if not 1 <= len(raw) <= 200 or any(b not in _KEY_CHARS for b in raw):
            raise BadRequest("Idempotency-Key must be 1 to 200 visible ASCII characters (a UUID is a good one)")
        return raw.decode("ascii")

    @staticmethod
    def _actor(scope: Scope, headers: dict[bytes, bytes]) -> str:
        keys = scope["app"].state.api_keys
        if not keys:
            return security.ANONYMOUS
        try:
            return security.authenticate(keys, headers.get(b"x-api-key", b"").decode("latin-1")).name
        except Unauthorized as exc:
            raise _Unauthenticated from exc

    async def _answer_stored(
        self, stored: store.Stored, digest: str, scope: Scope, receive: Receive, send: Send
    ) -> None:
        if stored.body_sha256 != digest or stored.path != scope["path"][:500]:
            exc: ServiceError = IdempotencyKeyReused(
                "this Idempotency-Key was used for another request; use a new key for a new request"
            )
        elif stored.status is None:
            exc = Conflict("the first request with this Idempotency-Key is still running; retry", retry_after=1)
        else:
            headers = [(b"content-length", str(len(stored.body or b"")).encode()), (b"idempotent-replayed", b"true")]
            if stored.content_type:
                headers.append((b"content-type", stored.content_type.encode("latin-1")))
            await send({"type": "http.response.start", "status": stored.status, "headers": headers})
            await send({"type": "http.response.body", "body": stored.body or b""})
            return
        await problems.response(problems.to_problem(exc))(scope, receive, send)

    async def _run_and_store(
        self, scope: Scope, receive: Receive, send: Send, body: bytes, *, db: Database, actor: str, key: str
    ) -> None:
        status = 500
        content_type: str | None = None
        chunks: list[bytes] = []

        async def capture(message: Message) -> None:
            nonlocal status, content_type
            if message["type"] == "http.response.start":
                status = int(message["status"])
                for name, value in message.get("headers", []):
                    if name.lower() == b"content-type":
                        content_type = value.decode("latin-1")
            elif message["type"] == "http.response.body":
                chunks.append(message.get("body", b""))
            with contextlib.suppress(OSError):  # the client left: the answer is still stored for its retry
                await send(message)

        try:
            await self.app(scope, replaying(body, receive), capture)
        except BaseException:
            with anyio.CancelScope(shield=True):
                await anyio.to_thread.run_sync(lambda: store.release(db, actor=actor, key=key))
            raise
        with anyio.CancelScope(shield=True):
            if status >= 500 or status in _NOT_STORED:
                await anyio.to_thread.run_sync(lambda: store.release(db, actor=actor, key=key))
            else:
                answer = b"".join(chunks)
                await anyio.to_thread.run_sync(
                    lambda: store.complete(
                        db,
                        actor=actor,
                        key=key,
                        status=status,
                        content_type=content_type,
                        body=answer,
                        ttl_s=IDEMPOTENCY_TTL_S,
                    )
                )


class _Unauthenticated(Exception):
    pass


class _Disconnected(Exception):
    pass


async def _read_body(receive: Receive) -> bytes:
    chunks: list[bytes] = []
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            raise _Disconnected
        chunks.append(message.get("body", b""))
        if not message.get("more_body", False):
            return b"".join(chunks)
