"""Functions are built once per robot structure, whatever the nominal values."""

from __future__ import annotations

import numpy as np

from models import FUNCTIONS, forward_kinematics, functions_for, iwr, sample_workspace


def test_one_build_per_structure() -> None:
    first = functions_for(iwr())
    builds = FUNCTIONS.builds
    other_base = iwr(base=(1000.0, 0.0, 0.0, 0.0, 0.0, 0.3), tool=(0.0, 0.0, 150.0, 0.0, 0.0, 0.0))
    assert functions_for(other_base) is first
    joints = sample_workspace(other_base, 20, seed=1)
    forward_kinematics(other_base, joints, jacobian=True)
    forward_kinematics(iwr(), joints)
    assert FUNCTIONS.builds == builds


def test_base_and_tool_are_inputs_not_graph_constants() -> None:
    plain, moved = iwr(), iwr(base=(0.0, 0.0, 100.0, 0.0, 0.0, 0.0))
    joints = sample_workspace(plain, 4, seed=2)
    a = forward_kinematics(plain, joints).positions
    b = forward_kinematics(moved, joints, moved.parameters.nominal).positions
    np.testing.assert_allclose(b - a, np.tile([0.0, 0.0, 100.0], (4, 1)), atol=1e-9)
