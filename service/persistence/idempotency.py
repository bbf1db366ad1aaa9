"""The idempotency_keys table (migration 0003): claim a key, store the first answer, replay it.

Each function is one short transaction of its own; none of them runs while the request computes.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta

from sqlalchemy import delete
from sqlalchemy.exc import IntegrityError

from service.persistence.database import Database
from service.persistence.tables import IdempotencyRecord


@dataclass(frozen=True)
class Stored:
    """What a key already holds: `status` None while its first request is still being answered."""

    path: str
    body_sha256: str
    status: int | None
    content_type: str | None
    body: bytes | None


def claim(
    db: Database, *, actor: str, key: str, method: str, path: str, body_sha256: str, in_flight_s: float
) -> Stored | None:
    """Claim `key` for this request (None), or return what it already holds. An expired row is replaced; a
    claim whose request never finished (the process died) expires after `in_flight_s`."""
    now = datetime.now(UTC)
    try:
        with db.session() as s:
            found = s.get(IdempotencyRecord, (actor, key))
            if found is not None and found.expires_at > now:
                return Stored(found.path, found.body_sha256, found.status, found.content_type, found.body)
            if found is not None:
                s.delete(found)
                s.flush()
            s.add(
                IdempotencyRecord(
                    actor=actor,
                    key=key,
                    method=method,
                    path=path,
                    body_sha256=body_sha256,
                    created_at=now,
                    expires_at=now + timedelta(seconds=in_flight_s),
                )
            )
    except IntegrityError:  # PostgreSQL: a concurrent request claimed it first
        return Stored(path, body_sha256, None, None, None)
    return None


def complete(
    db: Database, *, actor: str, key: str, status: int, content_type: str | None, body: bytes, ttl_s: float
) -> None:
    with db.session() as s:
        found = s.get(IdempotencyRecord, (actor, key))
        if found is not None:
            found.status, found.content_type, found.body = status, content_type, body
            found.expires_at = datetime.now(UTC) + timedelta(seconds=ttl_s)


def release(db: Database, *, actor: str, key: str) -> None:
    """Forget a claim whose answer must not be replayed (a 5xx, a 429): the retry runs again."""
    with db.session() as s:
        s.execute(delete(IdempotencyRecord).where(IdempotencyRecord.actor == actor, IdempotencyRecord.key == key))


def purge_expired(db: Database) -> int:
    with db.session() as s:
        result = s.execute(delete(IdempotencyRecord).where(IdempotencyRecord.expires_at <= datetime.now(UTC)))
        return int(getattr(result, "rowcount", 0) or 0)
