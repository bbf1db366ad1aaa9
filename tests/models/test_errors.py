"""The error tree: every class declares its fields, and every field reaches `.data` (the problem members)."""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np
import pytest

from models import errors
from models.campaign import make_campaign
from models.description.robot import RobotDescription
from models.identification import identify, pipeline
from models.identification.options import IdentificationOptions
from models.identification.solver import SolverRun
from models.simulation import measure, perturbed_robot
from models.workspace import sample_workspace
from tests.error_trees import check_declared_fields

CLASSES = [c for _, c in inspect.getmembers(errors, inspect.isclass) if issubclass(c, errors.CalibrationError)]
SAMPLE: dict[str, Any] = {
    "field": "joints",
    "reason": "collinear_positions",
    "value": 1.5,
    "allowed": ["a", "b"],
    "min": -1.0,
    "max": 2.0,
    "what": "joints",
    "expected": [-1, 10],
    "got": 3,
    "pose": 4,
    "joint": "q3",
    "unit": "deg",
    "count": 2,
    "draw": 7,
    "norm": 1.2,
    "needed": 9,
    "units": 3,
    "missing": 6,
    "kind": "pose",
    "name": "tool.rz",
    "target_mm": 0.05,
    "reachable_mm": 0.08,
    "candidates": 2000,
    "solver": "ipopt",
    "status": "Maximum_Iterations_Exceeded",
    "iterations": 100,
    "rms_sigma": 250.0,
    "limit_sigma": 100.0,
}


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_field_is_declared_and_appears_in_data(cls: type[errors.CalibrationError]) -> None:
    check_declared_fields(cls, SAMPLE)


def test_the_tree_in_the_docstring_names_every_class_and_its_fields() -> None:
    doc = errors.__doc__ or ""
    for cls in CLASSES:
        assert f"{cls.__name__}({', '.join(cls.fields)}" in doc, cls.__name__


def test_fields_left_unknown_are_absent_not_null() -> None:
    exc = errors.NonFiniteValue("weights must be finite", field="weights")
    assert exc.data == {"field": "weights"}


def test_campaign_errors_name_the_pose(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 3, seed=1)
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
    quats[2] = [2.0, 0.0, 0.0, 0.0]
    with pytest.raises(errors.InvalidQuaternion) as err:
        make_campaign(desc, joints, np.zeros((3, 3)), quats)
    assert err.value.data == {"pose": 2, "norm": 2.0, "count": 1}


def test_workspace_errors_are_domain_errors(desc: RobotDescription) -> None:
    with pytest.raises(errors.InvalidInput) as err:
        sample_workspace(desc, -1)
    assert err.value.data["field"] == "n"


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_strict_identification_raises_what_a_failed_result_reports(
    desc: RobotDescription, monkeypatch: pytest.MonkeyPatch
) -> None:
    sim = perturbed_robot(desc, seed=5)
    campaign = measure(sim, sample_workspace(desc, 40, seed=6), seed=7)
    options = IdentificationOptions(max_iterations=1)

    # IPOPT stopped after one iteration, and the trust-region finish (which converges from there on its own)
    # stopped as well: a run that truly failed, whose report strict mode must raise.
    def stopped(problem: Any, z0: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> SolverRun:
        return SolverRun(z=z0, status="stopped (test)", success=False, iterations=0, seconds=0.0, objective=0.0)

    monkeypatch.setattr(pipeline, "trust_region_finish", stopped)
    failed = identify(desc, campaign, options=options)
    assert failed.status == "failed" and not failed.solver.success
    with pytest.raises(errors.SolverFailed) as err:
        identify(desc, campaign, options=options, strict=True)
    assert err.value.data["iterations"] == failed.solver.iterations
    assert err.value.detail == failed.reason

    # Measurements of another robot (positions scaled by 1.5): residuals of hundreds of σ.
    wrong = make_campaign(desc, campaign.joints, campaign.positions * 1.5, campaign.quaternions)
    inconsistent = identify(desc, wrong)
    assert inconsistent.status == "failed"
    with pytest.raises(errors.InconsistentData) as bad:
        identify(desc, wrong, strict=True)
    assert bad.value.data["limit_sigma"] == 100.0


def test_bounds_are_numbers_in_order_and_name_parameters(desc: RobotDescription) -> None:
    sim = perturbed_robot(desc, seed=8)
    campaign = measure(sim, sample_workspace(desc, 30, seed=9), seed=10)
    for bad in ({"link1.a": (92.0, 90.0)}, {"link1.a": (float("nan"), 95.0)}, {"link9.a": (0.0, 1.0)}):
        with pytest.raises(errors.InvalidInput) as err:
            identify(desc, campaign, options=IdentificationOptions(bounds=bad))
        assert err.value.data["field"] == next(iter(bad))
    # Infinite bounds mean "no bound" on that side.
    assert identify(desc, campaign, options=IdentificationOptions(bounds={"link1.a": (-np.inf, np.inf)})).succeeded
