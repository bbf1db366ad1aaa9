"""Compensation under the model terms: commands that are right at the temperature and load they run at."""

from __future__ import annotations

import numpy as np
import pytest

from models import forward_kinematics, iwr, sample_workspace
from models.compensation import compensate, correct_program
from models.description.terms import ModelTerms, make_conditions
from models.transforms import matrix_to_quaternion

DESC = iwr().with_terms(ModelTerms(thermal=True, compliance=True))
THETA = DESC.parameters.with_values(
    DESC.parameters.nominal, {"thermal.legs": 20e-6, "thermal.axes": 15e-6, "compliance.leg2": 0.3e-3}
)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_compensation_reaches_the_targets_under_their_conditions() -> None:
    q = sample_workspace(iwr(), 10, seed=3)
    cond = make_conditions(10, np.linspace(15.0, 30.0, 10), 40.0, [0.0, 0.0, 150.0])
    target = forward_kinematics(DESC, q, THETA, conditions=cond)
    quats = matrix_to_quaternion(target.rotations)
    sol = compensate(DESC, THETA, target.positions, quats, conditions=cond, seed=q)
    assert sol.reachable.all()
    # independent check: the terms' forward kinematics at the commands and the same conditions
    reached = forward_kinematics(DESC, sol.joints, THETA, conditions=cond, check_ranges=False)
    assert np.linalg.norm(reached.positions - target.positions, axis=1).max() < 1e-8
    # the geometric compensation of the same targets misses them at these temperatures and this load
    geometric = compensate(iwr(), THETA[:70], target.positions, quats, seed=q)
    missed = forward_kinematics(DESC, geometric.joints, THETA, conditions=cond, check_ranges=False).positions
    assert np.linalg.norm(missed - target.positions, axis=1).max() > 0.02


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_corrected_program_holds_at_its_temperature() -> None:
    program = sample_workspace(iwr(), 5, seed=4)
    hot = make_conditions(5, 27.0, 10.0, [0.0, 0.0, 100.0])
    sol = correct_program(DESC, program, THETA, conditions=hot)
    assert sol.reachable.all()
    promised = forward_kinematics(iwr(), program, np.r_[DESC.parameters.nominal[:70]]).positions
    promised_at = forward_kinematics(DESC, sol.joints, THETA, conditions=hot, check_ranges=False).positions
    base = DESC.slices["base"]
    assert np.allclose(THETA[base], DESC.parameters.nominal[base])  # same base: the promise is the nominal pose
    assert np.linalg.norm(promised_at - promised, axis=1).max() < 1e-8
