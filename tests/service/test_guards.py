"""Bodies: read on a deadline, large JSON checked off the loop, error lists capped, chunked bodies counted."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest
from fastapi.testclient import TestClient
from starlette.types import Message

from service import guards
from service.problems import MAX_ERRORS
from tests.service.conftest import make_client

JOINTS = [400.0, 150.0, 90.0, 45.0, 420.0, 420.0, 420.0, 420.0, 420.0, 420.0]


@pytest.mark.serial  # refused within 2 s of wall time: alone on the cores
def test_a_body_of_unknown_keys_is_refused_quickly_and_briefly(client: TestClient, robot_id: str) -> None:
    bomb = "{" + ",".join(f'"k{i}":0' for i in range(300_000)) + "}"  # 3.5 MB: 6.9 s and 19.7 MB on main
    started = time.perf_counter()
    r = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics", content=bomb, headers={"content-type": "application/json"}
    )
    assert r.status_code == 422 and "300000 keys" in r.json()["detail"]
    assert len(r.content) < 1000 and time.perf_counter() - started < 2.0


def test_error_lists_are_capped(client: TestClient, robot_id: str) -> None:
    bad = [[*JOINTS[:9], "x"]] * 200  # small enough to skip the shape check, 200 errors
    r = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": bad})
    assert r.status_code == 422
    assert len(r.json()["errors"]) == MAX_ERRORS and r.json()["error_count"] == 200


def test_a_chunked_body_over_the_limit_is_a_413_like_a_sized_one(tmp_path: Path) -> None:
    def chunks() -> Iterator[bytes]:
        yield b'{"name": "'
        for _ in range(20):
            yield b"x" * 100
        yield b'"}'

    with make_client(f"sqlite:///{tmp_path}/c.db", max_body_bytes=1000) as c:
        chunked = c.post("/v1/robots", content=chunks(), headers={"content-type": "application/json"})
        sized = c.post("/v1/robots", json={"name": "x" * 2000})
    assert chunked.status_code == sized.status_code == 413
    assert chunked.json()["type"] == sized.json()["type"]


def test_a_slow_body_times_out(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(guards, "BODY_TIMEOUT_S", 0.2)
    sent: list[Message] = []
    reached = False

    async def app(scope: object, receive: object, send: object) -> None:
        nonlocal reached
        reached = True

    async def trickle() -> Message:
        await anyio.sleep(0.1)
        return {"type": "http.request", "body": b"x", "more_body": True}  # never the last chunk

    async def send(message: Message) -> None:
        sent.append(message)

    scope = {"type": "http", "method": "POST", "path": "/v1/robots", "headers": []}
    anyio.run(guards.BodyGuard(app, limit=1_000_000), scope, trickle, send)  # type: ignore[arg-type]
    assert not reached and sent[0]["status"] == 408


@pytest.mark.serial  # refused within 0.5 s of wall time: alone on the cores
def test_kinematics_over_the_budget_are_refused_before_parsing(client: TestClient, robot_id: str) -> None:
    vectors = [JOINTS] * 100_000  # the schema's maximum: 58 000 fit the budget (service.limits)
    fk = json.dumps({"joints": vectors}).encode()
    targets = [{"position": [1.0, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]}] * 3_000
    ik = json.dumps({"targets": targets, "seed": JOINTS}).encode()
    assert guards._joint_vectors(fk) == len(vectors) and guards._targets(ik) == len(targets)  # the counts are exact
    for path, body in (("forward-kinematics", fk), ("inverse-kinematics", ik)):
        started = time.perf_counter()
        r = client.post(f"/v1/robots/{robot_id}/{path}", content=body, headers={"content-type": "application/json"})
        elapsed = time.perf_counter() - started
        assert r.status_code == 422 and r.json()["type"].endswith("work-too-large"), r.text[:300]
        assert "send fewer" in r.json()["detail"] and elapsed < 0.5  # parsing and validating 7 MB: 0.8 s here
    within = json.dumps({"joints": [JOINTS] * 2_000}).encode()  # over 64 kB, within the budget: computed
    r = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics", content=within, headers={"content-type": "application/json"}
    )
    assert r.status_code == 200 and len(r.json()["poses"]) == 2_000
