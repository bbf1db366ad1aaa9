"""URDF trees: a dual-arm torso URDF (written for these tests in the shape of a YuMi- or SDA-class robot: a
waist under two 7R arms on tilted shoulders) read with its two grippers as tips. Its FK against a hand-written
walk of the URDF's joints (numpy, always) and against Pinocchio (when installed)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.errors import InvalidInput
from models.tree import tool_poses, tree_from_urdf, tree_joint_samples

URDF = (Path(__file__).parent / "fixtures" / "dual_arm_torso.urdf").read_text()
TIPS = ["gripper_l", "gripper_r"]


def _attr(element: ET.Element, child: str, key: str) -> str:
    found = element.find(child)
    assert found is not None and found.get(key) is not None, f"<{child} {key}> missing"
    return str(found.get(key))


def _urdf_fk(urdf: str, tip: str, joints: dict[str, float]) -> np.ndarray:
    """world <- tip (mm) by walking the URDF's joints from the root: origin (xyz, rpy fixed-axis) then the
    joint's rotation about its axis. Independent of yourdfpy and of the models' import."""
    root = ET.fromstring(urdf)
    parent_joint = {_attr(j, "child", "link"): j for j in root.iter("joint")}
    chain, at = [], tip
    while at in parent_joint:
        chain.append(parent_joint[at])
        at = _attr(parent_joint[at], "parent", "link")
    t = np.eye(4)
    for joint in reversed(chain):
        xyz = [float(v) for v in _attr(joint, "origin", "xyz").split()]
        rpy = [float(v) for v in _attr(joint, "origin", "rpy").split()]
        step = np.eye(4)
        step[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF: roll, pitch, yaw about fixed axes
        step[:3, 3] = np.array(xyz) * 1000.0
        if joint.get("type") == "revolute":
            axis = np.array([float(v) for v in _attr(joint, "axis", "xyz").split()])
            turn = np.eye(4)
            turn[:3, :3] = Rotation.from_rotvec(axis * joints[str(joint.get("name"))]).as_matrix()
            step = step @ turn
        t = t @ step
    return t


def test_the_trunk_is_the_common_prefix_and_the_arms_hang_from_it() -> None:
    tree = tree_from_urdf(URDF, "world", TIPS)
    assert [(b.name, b.parent, b.joint_names) for b in tree.branches] == [
        ("body", None, ("waist_joint",)),
        ("gripper_l", "body", tuple(f"joint_{k}_l" for k in range(1, 8))),
        ("gripper_r", "body", tuple(f"joint_{k}_r" for k in range(1, 8))),
    ]
    assert tree.tips == ("gripper_l", "gripper_r")
    assert tree.n_joints == 15


def test_fk_of_both_tips_equals_a_hand_written_walk_of_the_urdf() -> None:
    tree = tree_from_urdf(URDF, "world", TIPS)
    q = tree_joint_samples(tree, 5, seed=2)
    for tip in TIPS:
        ours = tool_poses(tree, tip, q)
        for i in range(q.shape[0]):
            expected = _urdf_fk(URDF, tip, dict(zip(tree.joint_names, q[i], strict=True)))
            np.testing.assert_allclose(ours.positions[i], expected[:3, 3], atol=1e-9)  # mm
            np.testing.assert_allclose(ours.rotations[i], expected[:3, :3], atol=1e-12)


def test_fk_of_both_tips_equals_pinocchio() -> None:
    pin = pytest.importorskip(
        "pinocchio", reason="Pinocchio is not installed (`pip install pin`, the dev extra): the numpy check ran"
    )
    tree = tree_from_urdf(URDF, "world", TIPS)
    model = pin.buildModelFromXML(URDF)
    data = model.createData()
    q = tree_joint_samples(tree, 5, seed=3)
    index = [model.joints[model.getJointId(name)].idx_q for name in tree.joint_names]
    for i in range(q.shape[0]):
        configuration = pin.neutral(model)
        configuration[index] = q[i]
        pin.framesForwardKinematics(model, data, configuration)
        for tip in TIPS:
            frame = data.oMf[model.getFrameId(tip)]
            ours = tool_poses(tree, tip, q[i : i + 1])
            np.testing.assert_allclose(ours.positions[0], frame.translation * 1000.0, atol=1e-6)  # 1e-6 mm
            np.testing.assert_allclose(ours.rotations[0], frame.rotation, atol=1e-12)


def test_bad_tips_are_named() -> None:
    with pytest.raises(InvalidInput, match="no link 'hand'"):
        tree_from_urdf(URDF, "world", ["gripper_l", "hand"])
    with pytest.raises(InvalidInput, match="different tip links"):
        tree_from_urdf(URDF, "world", ["gripper_l", "gripper_l"])
    with pytest.raises(InvalidInput, match="'gripper_l' is not below 'shoulder_r'"):
        tree_from_urdf(URDF, "shoulder_r", ["gripper_l", "gripper_r"])
