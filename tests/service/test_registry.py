"""The service owns its robot runtimes: every models call of every operation goes through the app's registry.

The process-wide `models.default_registry()` is replaced by one that refuses to serve, so any call of the
service that forgot `runtime=` fails (a 500 the contract client reports) instead of silently building a second
copy of the Functions, solvers and tables outside the app's registry.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import models.engine.runtime
from models import Registry, RobotDescription, forward_kinematics, iwr, sample_workspace
from models.simulation import perturbed_robot
from models.transforms import matrix_to_quaternion
from service.compute.registry import IWR_TERMS, build_registry
from service.settings import Settings
from tests.service.conftest import make_client
from tests.service.helpers import finished_job, records

DESC = iwr()


class Refusing(Registry):
    """Stands in for the process-wide default registry: any call that reaches it is a missing `runtime=`."""

    def runtime(self, desc: RobotDescription) -> models.engine.runtime.Runtime:
        raise AssertionError(f"a models call fell back to the default registry (structure {desc.structure!r})")


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_every_operation_uses_the_apps_registry(tmp_path: Path, registry: Registry) -> None:
    # The truth, computed before the default registry is refused: a perturbed robot and its measurements.
    sim = perturbed_robot(DESC, seed=17)
    joints = sample_workspace(DESC, 40, seed=5)
    recs = records(DESC, sim, joints, seed=6)
    check = sample_workspace(DESC, 6, seed=8)
    fk = forward_kinematics(DESC, check, runtime=registry.runtime(DESC))
    targets = [
        {"position": p.tolist(), "orientation": q.tolist()}
        for p, q in zip(fk.positions, matrix_to_quaternion(fk.rotations), strict=True)
    ]
    with make_client(f"sqlite:///{tmp_path}/r.db", registry) as api, pytest.MonkeyPatch.context() as mp:
        assert api.app.state.registry is registry  # type: ignore[attr-defined]
        mp.setattr(models.engine.runtime, "_DEFAULT_REGISTRY", Refusing())
        rid = api.post("/v1/robots", json={"name": "owned"}).json()["id"]
        deg = (check * DESC.joint_to_boundary).tolist()
        poses = api.post(f"/v1/robots/{rid}/forward-kinematics", json={"joints": deg}).json()["poses"]
        np.testing.assert_allclose([p["position"] for p in poses], fk.positions, atol=1e-9)
        ik = api.post(f"/v1/robots/{rid}/inverse-kinematics", json={"targets": targets}).json()
        assert all(ik["reachable"]) and max(ik["position_error_mm"]) < 1e-6
        design = api.post(f"/v1/robots/{rid}/pose-designs", json={"count": 12, "candidate_count": 100})
        assert design.status_code == 201 and len(design.json()["poses"]) == 12
        target = api.post(
            f"/v1/robots/{rid}/pose-designs", json={"target": {"rms_tcp_mm": 0.5}, "candidate_count": 100}
        )
        assert target.status_code == 201, target.text
        calibration = api.post(f"/v1/robots/{rid}/calibrations", json={"measurements": recs})
        assert calibration.status_code == 201, calibration.text
        assert calibration.json()["parameter_version"] == 2
        validation = api.post(f"/v1/robots/{rid}/validations", json={"measurements": recs[:10]})
        assert validation.status_code == 201, validation.text
        assert api.post(f"/v1/robots/{rid}/iso9283-poses", json={}).status_code == 200
        assert api.post("/v1/error-analysis", json={"poses": 4, "draws": 5}).status_code == 200
        job = api.post(f"/v1/robots/{rid}/calibrations?async=true", json={"measurements": recs, "apply": False})
        assert job.status_code == 202
        assert finished_job(api, job.json()["status_url"])["status"] == "succeeded"


@pytest.mark.slow  # a fresh registry builds every layer of the IWR: ~3 s here
def test_build_registry_warms_the_iwr_only_when_asked(tmp_path: Path) -> None:
    cold = build_registry(Settings(database_url=f"sqlite:///{tmp_path}/c.db", warm_up=False))
    assert len(cold) == 0
    warm = build_registry(Settings(database_url=f"sqlite:///{tmp_path}/w.db", warm_up=True))
    # The IWR's structure and its three structures with model terms (IWR_TERMS), and nothing else.
    structures = {rt.structure: rt for rt in warm}
    assert set(structures) == {DESC.structure, *(DESC.with_terms(t).structure for t in IWR_TERMS)}
    runtime = structures[DESC.structure]
    # Every layer's artefacts were built once, ahead of any request.
    assert runtime.builds["kinematics"] == 1 and len(runtime.builds) > 1
