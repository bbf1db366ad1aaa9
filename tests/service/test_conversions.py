"""The conversions build, from the domain's fields, exactly what the domain's `to_dict` methods used to give
clients (while those methods still exist: the integrator deletes them, and these comparisons with them).

Also: schema defaults and enums are the domain's own."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest

from models import iwr, sample_workspace
from models.compensation import inverse_kinematics
from models.error_analysis import DISTRIBUTIONS, Tolerances, error_analysis
from models.identifiability import NoiseModel
from models.identification import IdentificationOptions, identify
from models.identification.options import DEFAULT_GROUPS
from models.kinematics import forward_kinematics
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion
from optimal_design import design_poses
from optimal_design.criteria import Criterion
from optimal_design.design import MAX_CANDIDATES
from service.conversions import calibrations, designs, kinematics
from service.conversions import error_analysis as analysis
from service.schemas.calibrations import CalibrationCreate
from service.schemas.designs import PoseDesignCreate
from service.schemas.error_analysis import Distribution, ErrorAnalysisRequest

DESC = iwr()


def _json(value: Any) -> Any:
    """What the service used to send: to_dict's output with NaN and infinities as null."""

    def strict(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {k: strict(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [strict(x) for x in v]
        return v

    return json.loads(json.dumps(strict(value)))


def _needs(obj: object) -> None:
    if not hasattr(obj, "to_dict"):
        pytest.skip("the domain's to_dict is gone: nothing left to compare with")


@pytest.mark.parametrize("position_only", [False, True])
def test_calibration_report_equals_the_old_payload(position_only: bool) -> None:
    sim = perturbed_robot(DESC, seed=3)
    campaign = measure(sim, sample_workspace(DESC, 40, seed=4), seed=5, position_only=position_only)
    start = DESC.parameters.nominal.copy()
    start[DESC.parameters.index["tool.z"]] += 0.3  # a start version that is not the nominal geometry
    result = identify(DESC, campaign, nominal=start)
    _needs(result)
    old = _json(result.to_dict())
    nominal, begun = DESC.parameters.as_boundary(DESC.parameters.nominal), DESC.parameters.as_boundary(start)
    for i, entry in enumerate(old["parameters"]):
        entry["nominal"], entry["start"] = float(nominal[i]), float(begun[i])
    old["start_version"] = 4
    new = calibrations.report_out(DESC, result, start_values=start, start_version=4).model_dump(mode="json")
    assert new == old
    assert ("rms_deg" in new["residuals"]["after"]) is not position_only


def test_design_report_equals_the_old_payload() -> None:
    candidates = sample_workspace(DESC, 60, seed=6)
    design = design_poses(DESC, 12, "D", candidates=candidates)
    _needs(design)
    old = _json(design.to_dict(DESC, include_indices=True))
    assert designs.report_out(DESC, design, candidates_given=True).model_dump(mode="json") == old
    sampled = design_poses(DESC, 12, "condition", candidate_count=60)
    old = {**_json(sampled.to_dict(DESC, include_indices=False)), "indices": None}
    assert designs.report_out(DESC, sampled, candidates_given=False).model_dump(mode="json") == old


def test_inverse_kinematics_answer_equals_the_old_payload() -> None:
    fk = forward_kinematics(DESC, sample_workspace(DESC, 4, seed=7))
    targets = np.vstack([fk.positions, [[1e5, 0, 0]]])  # the last one far out of reach
    quats = np.vstack([matrix_to_quaternion(fk.rotations), [[1, 0, 0, 0]]])
    answer = inverse_kinematics(DESC, targets, quats, DESC.parameters.nominal)
    _needs(answer)
    assert kinematics.inverse_out(DESC, answer).model_dump(mode="json") == _json(answer.to_dict(DESC))


def test_error_analysis_report_equals_the_old_payload() -> None:
    result = error_analysis(DESC, n_poses=3, n_draws=5, seed=2)
    _needs(result)
    assert analysis.report_out(result).model_dump(mode="json") == _json(result.to_dict())


def test_schema_defaults_and_enums_are_the_domain_s() -> None:
    body = CalibrationCreate.model_validate({"measurements": [{"joints": [0] * 10, "position": [0, 0, 0]}]})
    options = calibrations.options_in(body)
    assert options == IdentificationOptions(estimate=DEFAULT_GROUPS)
    noise = calibrations.noise_in(body)
    assert noise.position_mm == NoiseModel().position_mm
    assert noise.orientation_rad == pytest.approx(NoiseModel().orientation_rad, rel=1e-12)
    design = PoseDesignCreate(count=3)
    assert design.criterion is Criterion.D
    properties = PoseDesignCreate.model_json_schema()["properties"]
    assert properties["candidate_count"]["maximum"] == MAX_CANDIDATES
    assert analysis.tolerances_in(ErrorAnalysisRequest()) == Tolerances()
    assert set(Distribution.__args__) == set(DISTRIBUTIONS)  # type: ignore[attr-defined]
