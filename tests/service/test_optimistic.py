"""Two writers cannot lose each other's work: a calibration applies only over the version it started from."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

import pytest

from models import Registry, identification, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.services import calibrations
from tests.service.conftest import make_client
from tests.service.contract_check import ContractClient
from tests.service.helpers import records

DESC = iwr()
RECS = records(DESC, perturbed_robot(DESC, seed=3), sample_workspace(DESC, 40, seed=5), seed=6)


@pytest.fixture
def api(database_url: str, registry: Registry) -> Iterator[ContractClient]:
    with make_client(database_url, registry) as c:
        yield c


def test_two_calibrations_in_flight_the_second_is_stored_not_applied(
    api: ContractClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The measured bug: two calibrations 0.5 s apart both applied; the later-finishing one silently won."""
    rid = api.post("/v1/robots", json={"name": "cell"}).json()["id"]
    slow_started, fast_done = threading.Event(), threading.Event()
    real = identification.identify  # the function calibrations imported

    calls = 0

    def identify(*args: Any, **kwargs: Any) -> Any:
        nonlocal calls
        calls += 1
        result = real(*args, **kwargs)
        if calls == 1:  # the first request's fit (it runs on a worker thread of the app)
            slow_started.set()
            assert fast_done.wait(60)  # the other calibration applies while this one "computes"
        return result

    monkeypatch.setattr(calibrations, "identify", identify)
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
