"""Bodies: read on a deadline, large JSON checked off the loop, error lists capped, chunked bodies counted."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel
from starlette.types import Message

from service import guards, json_bodies
from service.problems import MAX_ERRORS
from tests.service.conftest import make_client

JOINTS = [400.0, 150.0, 90.0, 45.0, 420.0, 420.0, 420.0, 420.0, 420.0, 420.0]


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


def test_a_large_declared_body_is_validated_off_the_loop_as_the_routes_model(
    client: TestClient, robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Over 64 kB, the body reaches the route already validated by `model_validate_json` in the parse process
    (threads in the tests): same answer as FastAPI's own path, and its errors located as FastAPI's are."""
    calls: list[str] = []
    original = json_bodies.validate_json

    def spy(model: type[BaseModel], raw: bytes) -> object:
        calls.append(model.__name__)
        return original(model, raw)

    monkeypatch.setattr(json_bodies, "validate_json", spy)
    vectors = [[*JOINTS[:3], 45.0 + k * 1e-3, *JOINTS[4:]] for k in range(2_000)]
    large = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors})
    small = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors[1990:]})
    assert calls == ["ForwardRequest"]  # the small one is FastAPI's, on the loop
    assert large.status_code == small.status_code == 200
    assert large.json()["poses"][1990:] == small.json()["poses"]
    vectors[1500] = [*JOINTS[:9], "x"]
    bad = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors})
    small_bad = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors[1500:1510]})
    assert bad.status_code == small_bad.status_code == 422 and calls == ["ForwardRequest"] * 2
    assert bad.json()["field"] == "joints[1500][9]" and small_bad.json()["field"] == "joints[0][9]"
    assert bad.json()["error_count"] == small_bad.json()["error_count"] == 1


def test_a_calibration_over_the_budget_is_refused_before_the_key_check(
    client: TestClient, robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    checked: list[int] = []
    monkeypatch.setattr(guards, "too_many_keys", lambda body: checked.append(len(body)))
    record = {"joints": JOINTS, "position": [1.0, 2.0, 3.0]}
    over = json.dumps({"measurements": [record] * 6_000}).encode()  # 6 000 x 0.36 ms: over the 2 s budget
    assert guards._records(over) == 6_000
    r = client.post(f"/v1/robots/{robot_id}/calibrations", content=over, headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["type"].endswith("work-too-large") and "?async=true" in r.json()["detail"]
    assert checked == []
    within = json.dumps({"measurements": [record] * 1_000}).encode()  # over 64 kB: checked, then validated
    r = client.post(f"/v1/robots/{robot_id}/calibrations", content=within, headers={"content-type": "application/json"})
    assert checked == [len(within)] and r.status_code != 500


def test_the_key_check_counts_every_object_and_leaves_malformed_json_to_the_parser() -> None:
    nested = json.dumps({"a": [{"b": {f"k{i}": i for i in range(65)}}]}).encode()
    assert guards.too_many_keys(nested) == 65
    assert guards.too_many_keys(json.dumps({"a": [{f"k{i}": i for i in range(64)}] * 3}).encode()) is None
    assert guards.too_many_keys(b'{"a": [1, 2') is None and guards.too_many_keys(b"[[[[]]]]") is None
