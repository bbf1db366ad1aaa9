"""Two writers cannot lose each other's work: a calibration applies only over the version it started from."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest

from models import Registry, identification, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.compute.model_cache import ModelCache
from service.jobs.runner import WorkerContext, execute_job
from service.services import pipelines
from tests.service.conftest import make_client
from tests.service.contract_check import ContractClient
from tests.service.helpers import records

DESC = iwr()
RECS = records(DESC, perturbed_robot(DESC, seed=3), sample_workspace(DESC, 40, seed=5), seed=6)


@pytest.fixture
def api(database_url: str, registry: Registry) -> Iterator[ContractClient]:
    with make_client(database_url, registry) as c:
        yield c


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_two_calibrations_in_flight_the_second_is_stored_not_applied(
    api: ContractClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The measured bug: two calibrations 0.5 s apart both applied; the later-finishing one silently won."""
    rid = api.post("/v1/robots", json={"name": "cell"}).json()["id"]
    slow_started, fast_done = threading.Event(), threading.Event()
    real = identification.identify  # the function the calibration pipeline imported

    calls = 0

    def identify(*args: Any, **kwargs: Any) -> Any:
        nonlocal calls
        calls += 1
        result = real(*args, **kwargs)
        if calls == 1:  # the first request's fit (it runs on a worker thread of the app)
            slow_started.set()
            assert fast_done.wait(60)  # the other calibration applies while this one "computes"
        return result

    monkeypatch.setattr(pipelines, "identify", identify)
    answers: dict[str, Any] = {}

    def slow() -> None:
        answers["slow"] = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS})

    thread = threading.Thread(target=slow)
    thread.start()
    assert slow_started.wait(60)
    fast = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS[::-1]})
    fast_done.set()
    thread.join(60)
    assert fast.status_code == 201 and fast.json()["applied"] and fast.json()["parameter_version"] == 2
    lost = answers["slow"]
    assert lost.status_code == 409, lost.text
    problem = lost.json()
    assert problem["start_version"] == 1 and problem["current_version"] == 2  # which version won
    stored = api.get(f"/v1/calibrations/{problem['calibration_id']}").json()
    assert stored["status"] == "succeeded" and not stored["applied"] and stored["parameter_version"] is None
    assert api.get(f"/v1/robots/{rid}/parameters").json()["version"] == 2  # the first writer's version stands


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_stale_start_version_does_not_apply(api: ContractClient) -> None:
    rid = api.post("/v1/robots", json={"name": "cell"}).json()["id"]
    assert api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS}).json()["parameter_version"] == 2
    stale = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS, "start_version": 1})
    assert stale.status_code == 409 and stale.json()["current_version"] == 2
    # Not applying was asked for: no conflict, the fit from version 1 is stored for comparison.
    review = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS, "start_version": 1, "apply": False})
    assert review.status_code == 201 and not review.json()["applied"]
    current = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS, "start_version": 2})
    assert current.status_code == 201 and current.json()["parameter_version"] == 3


class LateWorker:
    """Holds the app's jobs back (its `submit` only records them) and runs them when told: a worker that gets
    to a job after other writes, deterministically."""

    def __init__(self, api: ContractClient, registry: Registry, monkeypatch: pytest.MonkeyPatch) -> None:
        self.db = api.app.state.db  # type: ignore[attr-defined]
        self.registry, self.held = registry, list[str]()
        monkeypatch.setattr(api.app.state.jobs, "submit", self.hold)  # type: ignore[attr-defined]

    def hold(self, job_id: str, kind: str = "") -> None:
        del kind  # the Submitter's signature
        self.held.append(job_id)

    def run(self) -> None:
        ctx = WorkerContext(self.db, ModelCache(self.db), self.registry, lease=30, max_attempts=1)
        for job_id in self.held:
            assert execute_job(job_id, ctx).ran


@pytest.fixture
def worker(api: ContractClient, registry: Registry, monkeypatch: pytest.MonkeyPatch) -> LateWorker:
    return LateWorker(api, registry, monkeypatch)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_job_starts_from_the_version_current_at_submission(api: ContractClient, worker: LateWorker) -> None:
    """The probe: a job submitted at version 1 was applied as version 3 over a synchronous version 2, no 409."""
    rid = api.post("/v1/robots", json={"name": "cell"}).json()["id"]
    accepted = api.post(f"/v1/robots/{rid}/calibrations", params={"async": "true"}, json={"measurements": RECS})
    assert accepted.status_code == 202
    sync = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": RECS[::-1]})
    assert sync.status_code == 201 and sync.json()["parameter_version"] == 2
    worker.run()
    job = api.get(f"/v1/jobs/{accepted.json()['job_id']}").json()
    assert job["status"] == "succeeded"  # it did its work: the fit is stored for review
    result = job["result"]
    assert result["start_version"] == 1 and not result["applied"] and result["parameter_version"] is None
    assert result["not_applied_reason"].startswith("conflict:")
    assert "started from parameter version 1, and version 2 became current" in result["not_applied_reason"]
    assert api.get(f"/v1/robots/{rid}/parameters").json()["version"] == 2  # the synchronous writer's stands


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_job_with_nothing_in_between_applies(api: ContractClient, worker: LateWorker) -> None:
    rid = api.post("/v1/robots", json={"name": "cell"}).json()["id"]
    api.post(f"/v1/robots/{rid}/calibrations", params={"async": "true"}, json={"measurements": RECS})
    worker.run()
    assert api.get(f"/v1/robots/{rid}/parameters").json()["version"] == 2


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("run_async", [False, True])
def test_calibrations_honour_if_match(api: ContractClient, worker: LateWorker, run_async: bool) -> None:
    """The same ETag twice was 201, 201: the second now finds the robot changed (412, nothing stored)."""
    made = api.post("/v1/robots", json={"name": "cell"})
    rid, etag = made.json()["id"], made.headers["etag"]
    url, params = f"/v1/robots/{rid}/calibrations", {"async": "true"} if run_async else {}
    first = api.post(url, params=params, json={"measurements": RECS}, headers={"if-match": etag})
    assert first.status_code == (202 if run_async else 201), first.text
    worker.run()  # the job applies (nothing came in between): a new version, a new ETag
    second = api.post(url, params=params, json={"measurements": RECS}, headers={"if-match": etag})
    assert second.status_code == 412, second.text
    problem = second.json()
    assert problem["current"] == api.get(f"/v1/robots/{rid}").headers["etag"] and "read it again" in problem["detail"]
    assert len(api.get(url).json()) == 1  # the 412 stored no calibration, queued no job
    assert len(worker.held) == int(run_async)
    assert api.post(url, params=params, json={"measurements": RECS}, headers={"if-match": "*"}).is_success
