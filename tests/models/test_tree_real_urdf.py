"""Real URDF trees from a public package (example-robot-data, tests/robot_data.py): PAL Robotics' TALOS humanoid
(two torso joints under two 7-DoF arms, its grippers' fingers on mimic joints, meshes as package:// paths, the
head and legs off the hands' paths) and TIAGo dual (a prismatic torso lift under two 7-DoF arms, continuous
wheels beside them), each read with its two hands as tips. Both tools' FK at random joint vectors within the
limits against Pinocchio's reading of the same file (its own URDF parser and kinematics)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from models.errors import InvalidInput
from models.tree import RobotTree, tool_poses, tree_from_urdf, tree_joint_samples
from tests.models.tree_reference import pinocchio_tips
from tests.robot_data import robot_file

ROBOTS = {
    "talos": (
        "talos_data/robots/talos_reduced.urdf",
        "base_link",
        ("gripper_left_base_link", "gripper_right_base_link"),
    ),
    "tiago_dual": (
        "tiago_description/robots/tiago_dual.urdf",
        "base_footprint",
        ("hand_left_tool_link", "hand_right_tool_link"),
    ),
}
TRUNK = {"talos": ("torso_1_joint", "torso_2_joint"), "tiago_dual": ("torso_lift_joint",)}
SAMPLES = 24


@pytest.fixture(scope="session", params=sorted(ROBOTS))
def imported(request: pytest.FixtureRequest) -> tuple[str, str, RobotTree]:
    name = str(request.param)
    relative, base, tips = ROBOTS[name]
    text = robot_file(relative).read_text()
    return name, text, tree_from_urdf(text, base, list(tips), name=name)


@pytest.mark.slow  # the first test of each robot reads its 100-200-joint file: ~0.6 s of CPU
def test_the_trunk_carries_both_arms(imported: tuple[str, str, RobotTree]) -> None:
    name, _, tree = imported
    _, _, tips = ROBOTS[name]
    trunk, left, right = tree.branches
    assert trunk.joint_names == TRUNK[name] and trunk.parent is None and trunk.tool is None
    assert left.parent == right.parent == trunk.name
    assert left.joint_names == tuple(f"arm_left_{k}_joint" for k in range(1, 8))
    assert right.joint_names == tuple(f"arm_right_{k}_joint" for k in range(1, 8))
    assert tree.tips == tips
    assert tree.n_joints == len(TRUNK[name]) + 14
    if name == "tiago_dual":
        assert tree.joint_kinds[0].name == "LENGTH"  # the torso lift is prismatic: mm inside


@pytest.mark.slow  # Pinocchio's model of a 100-joint file and 2 x 24 poses of both tools: ~0.5 s of CPU
def test_fk_of_both_hands_equals_pinocchio(imported: tuple[str, str, RobotTree]) -> None:
    pin: Any = pytest.importorskip("pinocchio", reason="Pinocchio is not installed (`pip install pin`, the dev extra)")
    name, text, tree = imported
    q = tree_joint_samples(tree, SAMPLES, seed=47)
    frames = pinocchio_tips(pin, text, tree, q)  # the prismatic lift's mm are Pinocchio's metres
    worst = 0.0
    for tip in tree.tips:
        ours = tool_poses(tree, tip, q)
        worst = max(worst, float(np.abs(ours.positions - frames[tip][:, :3, 3]).max()))
        np.testing.assert_allclose(ours.rotations, frames[tip][:, :3, :3], atol=1e-12, err_msg=f"{name} {tip}")
    assert worst < 1e-6, f"{name}: {worst:.3g} mm"  # 1e-6 mm


@pytest.mark.slow  # reads the full TALOS file: ~0.7 s of CPU
def test_a_finger_on_a_mimic_joint_is_refused_naming_it() -> None:
    text = robot_file("talos_data/robots/talos_full_v2.urdf").read_text()
    with pytest.raises(InvalidInput, match="'gripper_left_inner_double_joint' mimics joint 'gripper_left_joint'"):
        tree_from_urdf(text, "base_link", ["gripper_left_fingertip_1_link", "gripper_right_base_link"])
