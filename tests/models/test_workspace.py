"""Workspace sampling: reproducible, inside every range, away from singularities."""

from __future__ import annotations

import numpy as np

from models import RobotDescription, forward_kinematics, sample_workspace
from models.kinematics import hexapod_condition


def test_seeded_and_reproducible(desc: RobotDescription) -> None:
    np.testing.assert_array_equal(sample_workspace(desc, 50, seed=3), sample_workspace(desc, 50, seed=3))
    assert not np.array_equal(sample_workspace(desc, 50, seed=3), sample_workspace(desc, 50, seed=4))


def test_samples_respect_ranges_strokes_and_conditioning(desc: RobotDescription) -> None:
    joints, platforms = sample_workspace(desc, 2000, seed=8, return_platforms=True)
    assert joints.shape == (2000, 10)
    assert np.all(joints >= desc.joint_min) and np.all(joints <= desc.joint_max)
    assert desc.hexapod is not None
    lo, hi = np.array(desc.hexapod.workspace_min), np.array(desc.hexapod.workspace_max)
    assert np.all(platforms >= lo) and np.all(platforms <= hi)
    assert np.all(hexapod_condition(desc, platforms, desc.parameters.nominal) <= desc.hexapod.max_condition)
    # the forward kinematics of the sampled legs recovers the sampled platform poses
    np.testing.assert_allclose(forward_kinematics(desc, joints).platforms, platforms, atol=1e-9)
