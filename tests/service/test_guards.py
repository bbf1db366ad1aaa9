"""Bodies: read on a deadline, large JSON checked off the loop, error lists capped, chunked bodies counted."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import anyio
import pytest
from fastapi.testclient import TestClient
from pydantic import BaseModel
from starlette.types import Message

from models import iwr, sample_workspace
from service.compute import dispatch
from service.http import guards, json_bodies, operations
from service.http.problems import MAX_ERRORS
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
    anyio.run(guards.BodyGuard(app, limit=1_000_000), scope, trickle, send)
    assert not reached and sent[0]["status"] == 408


@pytest.mark.serial  # refused within 0.5 s of wall time: alone on the cores
def test_kinematics_over_the_budget_are_refused_before_parsing(client: TestClient, robot_id: str) -> None:
    vectors = [JOINTS] * 100_000  # the schema's maximum: 58 000 fit the budget (service.compute.limits)
    fk = json.dumps({"joints": vectors}).encode()
    targets = [{"position": [1.0, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]}] * 3_000
    ik = json.dumps({"targets": targets, "seed": JOINTS}).encode()
    counted = operations.FORWARD_KINEMATICS.count(fk), operations.INVERSE_KINEMATICS.count(ik)
    assert counted == (len(vectors), len(targets))  # the counts are exact
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


def _where(calls: list[bool], original: Callable[[type[BaseModel], bytes], object]) -> Callable[..., object]:
    """A spy of `validate_json` that records whether it ran where an event loop runs."""

    def spy(model: type[BaseModel], raw: bytes) -> object:
        try:
            asyncio.get_running_loop()
            calls.append(True)
        except RuntimeError:
            calls.append(False)
        return original(model, raw)

    return spy


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_large_kinematics_body_is_validated_in_the_compute_task_not_on_the_loop(
    client: TestClient, robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Over 64 kB, forward kinematics' body travels as bytes and is validated where it is computed: same
    answer as on the loop, and its errors located the same way."""
    on_loop: list[bool] = []
    monkeypatch.setattr(dispatch, "validate_json", _where(on_loop, json_bodies.validate_json))
    monkeypatch.setattr(json_bodies, "validate_json", _where(on_loop, json_bodies.validate_json))
    vectors: list[list[float | str]] = [[*JOINTS[:3], 45.0 + k * 1e-3, *JOINTS[4:]] for k in range(2_000)]
    large = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors})
    assert on_loop == [False]
    small = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors[1990:]})
    assert on_loop == [False, True]  # a small one is validated on the loop: a hop would cost more
    assert large.status_code == small.status_code == 200
    assert large.json()["poses"][1990:] == small.json()["poses"]
    vectors[1500] = [*JOINTS[:9], "x"]
    bad = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors})
    small_bad = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": vectors[1500:1510]})
    assert bad.status_code == small_bad.status_code == 422 and on_loop == [False, True, False, True]
    assert bad.json()["field"] == "joints[1500][9]" and small_bad.json()["field"] == "joints[0][9]"
    assert bad.json()["error_count"] == small_bad.json()["error_count"] == 1
    assert client.post(f"/v1/robots/{robot_id}/forward-kinematics", content=b"").json()["field"] == ""
    text = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics", content=b"{}", headers={"content-type": "text/plain"}
    )
    assert text.status_code == 415


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_large_declared_body_is_validated_off_the_loop_as_the_routes_model(
    client: TestClient, robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Routes whose body FastAPI declares (OffloopRoute): over 64 kB, the body reaches the route already
    validated as its model by `model_validate_json` off the loop (a thread here, the parse process in a server)."""
    on_loop: list[bool] = []
    monkeypatch.setattr(json_bodies, "validate_json", _where(on_loop, json_bodies.validate_json))
    desc = iwr()
    candidates = (sample_workspace(desc, 600, seed=1) * desc.joint_to_boundary).tolist()
    body = {"count": 12, "criterion": "D", "candidates": candidates}
    assert len(json.dumps(body)) > guards.OFFLOOP_BYTES
    large = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body)
    assert large.status_code == 201 and on_loop == [False], large.text[:300]
    candidates[500][3] = "x"
    bad = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body)
    assert bad.status_code == 422 and bad.json()["field"] == "candidates[500][3]" and on_loop == [False, False]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_calibration_over_the_budget_is_refused_before_the_key_check(
    client: TestClient, robot_id: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    checked: list[int] = []
    monkeypatch.setattr(guards, "too_many_keys", lambda body: checked.append(len(body)))
    record = {"joints": JOINTS, "position": [1.0, 2.0, 3.0]}
    over = json.dumps({"measurements": [record] * 6_000}).encode()  # 6 000 x 0.36 ms: over the 2 s budget
    assert operations.CALIBRATION.count(over) == 6_000
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
