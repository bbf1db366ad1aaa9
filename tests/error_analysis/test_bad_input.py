"""Bad input is a domain error (InvalidInput) that names what is wrong."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from models import InvalidInput, NonFiniteValue, RobotDescription, UnreachablePose, WrongShape
from models.error_analysis import MAX_EVALUATIONS, ErrorMagnitudes, error_analysis, pose_errors
from models.simulation import thesis_perturbation


@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, "0.5", None, True])
@pytest.mark.parametrize("field", ["leg_offset", "joint_position", "dh_angle", "dh_length"])
def test_tolerances_must_be_finite_and_non_negative(field: str, value: Any) -> None:
    with pytest.raises(InvalidInput) as err:
        ErrorMagnitudes(**{field: value})
    assert err.value.data["field"] == field
    assert field in err.value.detail


def test_boundary_tolerances_are_checked_too() -> None:
    with pytest.raises(InvalidInput):
        ErrorMagnitudes.from_boundary(dh_angle_deg=-0.1)
    assert ErrorMagnitudes.from_boundary(dh_angle_deg=0.1).dh_angle == pytest.approx(math.radians(0.1))


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"n_poses": 0}, "n_poses"),
        ({"n_poses": -5}, "n_poses"),
        ({"n_poses": 2.5}, "n_poses"),
        ({"n_poses": True}, "n_poses"),
        ({"n_draws": 0}, "n_draws"),
        ({"n_poses": 1000, "n_draws": MAX_EVALUATIONS // 1000 + 1}, "n_draws"),
        ({"distribution": "gaussian"}, "distribution"),
        ({"seed": -1}, "seed"),
        ({"tolerances": {"dh_angle": 0.1}}, "tolerances"),
    ],
)
def test_study_arguments_are_checked(desc: RobotDescription, kwargs: dict[str, Any], field: str) -> None:
    with pytest.raises(InvalidInput) as err:
        error_analysis(desc, **kwargs)
    assert err.value.data["field"] == field


def test_pose_errors_checks_shapes_and_numbers(desc: RobotDescription) -> None:
    joints = np.array([[100.0, 100.0, 1.0, 0.5, 459.0, 459.0, 459.0, 459.0, 459.0, 459.0]])
    with pytest.raises(WrongShape):
        pose_errors(desc, joints, np.zeros(69))
    with pytest.raises(NonFiniteValue):
        pose_errors(desc, joints, np.full(desc.n_params, np.nan))
    with pytest.raises(WrongShape):
        pose_errors(desc, joints[:, :9], np.zeros(desc.n_params))


def test_tolerances_too_large_for_the_hexapod_say_so(desc: RobotDescription) -> None:
    with pytest.raises(UnreachablePose) as err:
        error_analysis(desc, n_poses=3, n_draws=2, tolerances=ErrorMagnitudes(leg_offset=60.0))
    assert err.value.data["draw"] == 0
    assert "smaller tolerances" in err.value.detail


def test_simulated_robots_are_perturbed_within_the_same_magnitudes(desc: RobotDescription) -> None:
    """`models.simulation` draws its true robots from the study's ErrorMagnitudes: uniform within ± each size,
    every carriage and hexapod parameter off (none skipped), base and tool left to their own errors."""
    magnitudes = ErrorMagnitudes(leg_offset=0.3, joint_position=0.05, dh_angle=0.002, dh_length=0.2)
    size = magnitudes.vector(desc)
    deltas = np.stack([thesis_perturbation(desc, np.random.default_rng(s), magnitudes) for s in range(200)])
    drawn = size > 0
    assert np.all(np.abs(deltas) <= size)
    assert np.all(deltas[:, ~drawn] == 0.0)
    # Uniform on ± size: the largest of 200 draws comes within 5 % of the bound for every parameter.
    assert np.all(np.abs(deltas[:, drawn]).max(axis=0) > 0.95 * size[drawn])
    assert set(np.unique(size[drawn])) == {0.3, 0.05, 0.002, 0.2}
