"""The same persistence tests on SQLite and on PostgreSQL (skipped, with the reason, where it is absent)."""

from __future__ import annotations

import time
from typing import Any

import pytest

from models import Registry, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.compute.model_cache import ModelCache
from service.errors import NotFound
from service.jobs import JobRunner, WorkerContext, execute_job
from service.persistence import Database, Repository
from service.schemas.calibrations import CalibrationCreate
from service.schemas.robots import RobotCreate
from service.services.calibrations import calibrate
from service.services.robots import create_robot
from service.settings import Settings
from tests.service.helpers import records

DESC = iwr()


def test_calibration_and_version_are_written_together(db: Database, registry: Registry) -> None:
    robot = create_robot(db=db, body=RobotCreate(name="r"))
    sim = perturbed_robot(DESC, seed=5)
    body = CalibrationCreate.model_validate(
        {"measurements": records(DESC, sim, sample_workspace(DESC, 30, seed=1), seed=2)}
    )
    record = calibrate(db=db, registry=registry, robot_id=robot.id, body=body)
    assert record.status == "succeeded" and record.parameter_version == 2
    with db.session() as s:
        repo = Repository(s)
        assert repo.robot(robot.id).current_version == 2
        version = repo.version(robot.id)
        assert version.calibration_id == record.id and version.provenance == "calibration"
        assert repo.version(robot.id, 1).provenance == "nominal"
        assert len(repo.calibrations(robot.id, 10, 0)) == 1
    # apply = false: stored, not applied
    again = calibrate(db=db, registry=registry, robot_id=robot.id, body=body.model_copy(update={"apply": False}))
    assert not again.applied and again.parameter_version is None
    with db.session() as s:
        assert Repository(s).robot(robot.id).current_version == 2
    db.migrate()  # idempotent: a restart migrates again, and what was written stays
    with db.reader() as s:
        assert (
            Repository(s).robot(robot.id).current_version == 2 and len(Repository(s).calibrations(robot.id, 10, 0)) == 2
        )


def test_a_failed_transaction_leaves_nothing(db: Database) -> None:
    robot = create_robot(db=db, body=RobotCreate(name="r"))
    with pytest.raises(RuntimeError), db.session() as s:
        repo = Repository(s)
        campaign = repo.add_campaign(robot.id, [{"joints": [0] * 10}])
        repo.add_calibration("c1", robot.id, campaign.id, "succeeded", {})
        raise RuntimeError("the computation failed after writing began")
    with db.session() as s, pytest.raises(NotFound):
        Repository(s).calibration("c1")


def test_delete_cascades_and_jobs_survive_a_restart(db: Database, registry: Registry) -> None:
    robot = create_robot(db=db, body=RobotCreate(name="r"))
    sim = perturbed_robot(DESC, seed=6)
    request = {"measurements": records(DESC, sim, sample_workspace(DESC, 25, seed=3), seed=4)}
    with db.session() as s:
        repo = Repository(s)
        queued = repo.add_job("calibration", robot.id, request)
        running = repo.add_job("calibration", robot.id, request)
        repo.start_job(running)
    # A new process starts: the queued job is resubmitted; the running one (no lease: started before leases
    # existed, by a process now gone) is not failed by the start-up but requeued by the lease check.
    runner = JobRunner(
        WorkerContext(db, ModelCache(db), registry),
        Settings(database_url=db.url, job_workers=0, warm_up=False),
    )
    assert runner.recover() == 1
    assert runner.reap() == (1, 0)
    for _ in range(400):  # both run in the runner's thread
        with db.session() as s:
            if {Repository(s).job(j.id).status for j in (queued, running)} == {"succeeded"}:
                break
        time.sleep(0.05)
    runner.shutdown()
    assert execute_job(queued.id, runner.context).status == "succeeded"  # a second delivery: nothing to do
    with db.session() as s:
        repo = Repository(s)
        for job in (queued, running):
            found = repo.job(job.id)
            assert found.status == "succeeded" and found.error is None, found.error
        assert len(repo.calibrations(robot.id, 10, 0)) == 2
    with db.session() as s:
        Repository(s).delete_robot(robot.id)
    with db.session() as s, pytest.raises(NotFound):
        Repository(s).robot(robot.id)


def test_which_calibrations_used_a_fleet_prior_is_read_from_their_documents(db: Database) -> None:
    """`fleet.prior_used` from the stored JSON without loading it: true, false, a null section, no section."""
    documents: dict[str, dict[str, Any]] = {
        "used": {"fleet": {"prior_used": True, "units": 5}},
        "not": {"fleet": {"prior_used": False}},
        "null": {"fleet": None},
        "none": {},
    }
    with db.session() as s:
        repo = Repository(s)
        robot = repo.add_robot("r", "iwr", [0.0] * 6, [0.0] * 6, [0.0] * 70)
        campaign = repo.add_campaign(robot.id, [{"joints": [0] * 10}])
        for name, document in documents.items():
            repo.add_calibration(name, robot.id, campaign.id, "succeeded", document)
    with db.reader() as s:
        found = Repository(s).calibrations_with_prior([*documents, "missing"])
    assert found == {"used": True, "not": False, "null": False, "none": False}
