"""Idempotency-Key: a retry replays the first answer and computes nothing; another request with the key is a 422."""

from __future__ import annotations

import time
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta

import httpx
import pytest
from sqlalchemy import update

from models import Registry, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.persistence.tables import IdempotencyRecord
from service.services import designs
from tests.service.conftest import make_client
from tests.service.contract_check import ContractClient
from tests.service.helpers import records

DESC = iwr()


@pytest.fixture
def api(database_url: str, registry: Registry) -> Iterator[ContractClient]:
    with make_client(database_url, registry) as c:
        yield c


def _campaign(n: int = 40) -> list[dict[str, object]]:
    return records(DESC, perturbed_robot(DESC, seed=3), sample_workspace(DESC, n, seed=5), seed=6)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_same_key_same_body_replays_without_computing(api: ContractClient, monkeypatch: pytest.MonkeyPatch) -> None:
    key = {"Idempotency-Key": "robot-1"}
    first = api.post("/v1/robots", json={"name": "a"}, headers=key)
    again = api.post("/v1/robots", json={"name": "a"}, headers=key)
    assert first.status_code == again.status_code == 201
    assert again.json() == first.json() and again.headers["idempotent-replayed"] == "true"
    assert len(api.get("/v1/robots").json()) == 1
    other = api.post("/v1/robots", json={"name": "b"}, headers=key)
    assert other.status_code == 422 and other.json()["type"].endswith("idempotency-key-reused")
    # No key: the request runs again (and the same name is a 409: names are unique), a new name a new robot.
    assert api.post("/v1/robots", json={"name": "a"}).status_code == 409
    assert api.post("/v1/robots", json={"name": "a2"}).status_code == 201
    assert len(api.get("/v1/robots").json()) == 2

    rid = first.json()["id"]
    calls = 0
    real = designs.create_design

    def counted(**kwargs: object) -> object:
        nonlocal calls
        calls += 1
        return real(**kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(designs, "create_design", counted)
    body = {"count": 20, "candidate_count": 200}
    d1 = api.post(f"/v1/robots/{rid}/pose-designs", json=body, headers={"Idempotency-Key": "d"})
    d2 = api.post(f"/v1/robots/{rid}/pose-designs", json=body, headers={"Idempotency-Key": "d"})
    assert d1.status_code == d2.status_code == 201 and d1.json() == d2.json() and calls == 1
    async_again = api.post(f"/v1/robots/{rid}/pose-designs?async=true", json=body, headers={"Idempotency-Key": "d"})
    assert async_again.status_code == 422  # the query is part of the request


def test_a_refusal_is_replayed_and_a_key_expires(api: ContractClient) -> None:
    key = {"Idempotency-Key": "k-422"}
    bad = api.post("/v1/robots", json={"name": ""}, headers=key)
    assert bad.status_code == 422 and api.post("/v1/robots", json={"name": ""}, headers=key).json() == bad.json()
    key = {"Idempotency-Key": "k-expiring"}
    first = api.post("/v1/robots", json={"name": "x"}, headers=key).json()
    db = api.app.state.db  # type: ignore[attr-defined]
    with db.session() as s:
        s.execute(update(IdempotencyRecord).values(expires_at=datetime.now(UTC) - timedelta(seconds=1)))
    fresh = api.post("/v1/robots", json={"name": "x"}, headers=key)
    # Expired: the request runs again rather than replaying (and meets the robot it made: names are unique).
    assert fresh.status_code == 409 and fresh.json()["id"] == first["id"] and "idempotent-replayed" not in fresh.headers


@pytest.mark.parametrize("bad", ["", "x" * 201, "tab\there", "é"])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_malformed_key_is_a_400(api: ContractClient, bad: str) -> None:
    r = api.post("/v1/robots", json={"name": "x"}, headers={"Idempotency-Key": bad.encode("utf-8")})
    assert r.status_code == 400 and "Idempotency-Key" in r.json()["detail"]


def test_keys_are_per_api_key(tmp_path: object) -> None:
    with make_client(f"sqlite:///{tmp_path}/k.db", api_keys="alpha-key-1,beta-key-2") as c:
        one = c.post("/v1/robots", json={"name": "r"}, headers={"X-API-Key": "alpha-key-1", "Idempotency-Key": "k"})
        two = c.post("/v1/robots", json={"name": "r"}, headers={"X-API-Key": "beta-key-2", "Idempotency-Key": "k"})
        # The second key's request runs (no replay of the first key's answer): it meets the name the first took.
        assert one.status_code == 201 and two.status_code == 409 and "idempotent-replayed" not in two.headers
        wrong = c.post("/v1/robots", json={"name": "r"}, headers={"X-API-Key": "nope", "Idempotency-Key": "k"})
        assert wrong.status_code == 401


@pytest.mark.slow
def test_a_client_that_times_out_and_retries_creates_one_calibration(story_url: str) -> None:
    """The measured bug: a retried POST after a client timeout created a second calibration and version."""
    with httpx.Client(base_url=story_url) as c:
        rid = c.post("/v1/robots", json={"name": "cell-retried"}).json()["id"]
        body = {"measurements": _campaign(400)}  # ~0.3 s of identification here: longer than the client waits
        headers = {"Idempotency-Key": "calibration-of-monday"}
        with pytest.raises(httpx.TimeoutException):
            c.post(f"/v1/robots/{rid}/calibrations", json=body, headers=headers, timeout=0.05)
        answers = []
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            r = c.post(f"/v1/robots/{rid}/calibrations", json=body, headers=headers, timeout=30)
            answers.append(r.status_code)
            if r.status_code != 409:
                break
            time.sleep(float(r.headers["retry-after"]) / 10)
        assert answers[-1] == 201 and set(answers[:-1]) <= {409}, answers
        assert r.headers["idempotent-replayed"] == "true"
        stored = c.get(f"/v1/robots/{rid}/calibrations").json()
        assert [s["id"] for s in stored] == [r.json()["id"]]
        assert c.get(f"/v1/robots/{rid}/parameters").json()["version"] == 2  # one new version, not two
