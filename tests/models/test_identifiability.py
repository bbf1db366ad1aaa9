"""Identifiability at the nominal geometry against the redundancy count of the issue.

70 parameters; a rigid motion of all b_i is a tool change (6 redundant); the
carriage with base frame and hexapod base plate has 4R + 2P + 6 = 18
independent parameters out of 22 + 6 (10 redundant): 54 identifiable from full
poses. Position-only data cannot see the tool orientation: 51.
"""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, RobotDescription, analyse_identifiability, forward_kinematics, sample_workspace
from models.identifiability import scaled_jacobian


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
@pytest.mark.parametrize(("position_only", "expected"), [(False, 54), (True, 51)])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_identifiable_count(desc: RobotDescription, position_only: bool, expected: int, seed: int) -> None:
    joints = sample_workspace(desc, 60, seed=seed)
    jac = forward_kinematics(desc, joints, jacobian=True).jacobians
    assert jac is not None
    scaled = scaled_jacobian(jac, desc.parameters, NoiseModel(), position_only=position_only)
    result = analyse_identifiability(scaled, desc.parameters)
    assert result.rank == expected
    assert len(result.identifiable) == expected
    assert len(result.unidentifiable) == desc.n_params - expected
    # the cut sits in a wide gap: the kept directions are far above round-off, the dropped ones at it
    s = result.singular_values
    assert s[expected - 1] / s[0] > 1e-7
    assert s[expected] / s[0] < 1e-13
    # the identified subset alone has full column rank
    sub = scaled[:, list(result.identifiable)]
    assert np.linalg.matrix_rank(sub, tol=s[0] * 1e-9) == expected


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_confounding_names_the_redundant_partner(desc: RobotDescription) -> None:
    """link1.theta (a rotation about the first z axis) is exactly a base rotation about z."""
    joints = sample_workspace(desc, 40, seed=5)
    jac = forward_kinematics(desc, joints, jacobian=True).jacobians
    assert jac is not None
    scaled = scaled_jacobian(jac, desc.parameters, NoiseModel(), position_only=False)
    result = analyse_identifiability(scaled, desc.parameters)
    by_name = {c.name: c for c in result.confounding}
    assert "link1.theta" in by_name
    partners = dict(by_name["link1.theta"].partners)
    assert "base.rz" in partners
    assert abs(abs(partners["base.rz"]) - 1.0) < 1e-6  # both scaled by 0.1°
