"""A calibrated tree written back. The URDF: read again by the tree importer and by Pinocchio, its FK of both
tips (with the reported world <- base_link and tip -> TCP) equals the calibrated tree's, on the fixture
dual-arm torso and on the real TALOS and TIAGo dual files. The DH tables: their numbers alone, composed by a
hand-written product (parent's end frame, the branch's base row, its links, its tool row), give every tool's
pose of the calibrated tree."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.errors import InvalidInput
from models.formats.dh_table import DhTable, FrameRow
from models.tree import RobotTree, perturbed_tree, tool_poses, tree_from_urdf, tree_joint_samples
from models.tree.examples import arm_with_positioner, dual_arm_torso
from models.tree.export import branch_dh_tables, calibrate_urdf_tree
from tests.models.tree_reference import pinocchio_tips
from tests.robot_data import robot_file

FIXTURE = (Path(__file__).parent / "fixtures" / "dual_arm_torso.urdf").read_text()
TALOS_HANDS = ("gripper_left_base_link", "gripper_right_base_link")
TIAGO_HANDS = ("hand_left_tool_link", "hand_right_tool_link")
URDFS = {
    "fixture": (None, "world", ("gripper_l", "gripper_r")),
    "talos": ("talos_data/robots/talos_reduced.urdf", "base_link", TALOS_HANDS),
    "tiago_dual": ("tiago_description/robots/tiago_dual.urdf", "base_footprint", TIAGO_HANDS),
}
SAMPLES = 20


def _matrices(positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    t = np.tile(np.eye(4), (positions.shape[0], 1, 1))
    t[:, :3, :3], t[:, :3, 3] = rotations, positions
    return t


@pytest.fixture(scope="session", params=sorted(URDFS))
def exported(request: pytest.FixtureRequest) -> tuple[str, RobotTree, np.ndarray, Any]:
    relative, base, tips = URDFS[str(request.param)]
    text = FIXTURE if relative is None else robot_file(relative).read_text()
    tree = tree_from_urdf(text, base, list(tips))
    truth = perturbed_tree(tree, seed=3).truth
    return base, tree, truth, calibrate_urdf_tree(text, base, tree, truth)


@pytest.mark.slow  # each file read three times and its calibrated origins spliced: 0.3-1 s of CPU
def test_the_calibrated_urdf_read_again_is_the_calibrated_tree(
    exported: tuple[str, RobotTree, np.ndarray, Any],
) -> None:
    base, tree, truth, calibration = exported
    again = tree_from_urdf(calibration.urdf, base, list(tree.tips))
    # Drop-in: the same branches, joints and names, only origins changed.
    assert [(b.name, b.parent, b.joint_names) for b in again.branches] == [
        (b.name, b.parent, b.joint_names) for b in tree.branches
    ]
    assert set(calibration.origins) == {name for b in tree.branches for name in b.joint_names or ()}
    q = tree_joint_samples(tree, SAMPLES, seed=4)
    to_link = np.linalg.inv(calibration.world_from_base_link)
    for tip in tree.tips:
        ours = tool_poses(tree, tip, q, truth)
        expected = to_link @ _matrices(ours.positions, ours.rotations) @ np.linalg.inv(calibration.tip_to_tcp[tip])
        got = tool_poses(again, tip, q)
        assert np.abs(got.positions - expected[:, :3, 3]).max() < 1e-6  # mm
        assert np.abs(got.rotations - expected[:, :3, :3]).max() < 1e-9
        # The calibration moved the tips by millimetres: the check is not of a nominal file against itself.
        nominal = tool_poses(tree, tip, q)
        assert np.abs(nominal.positions - got.positions).max() > 0.5


@pytest.mark.slow  # Pinocchio's model of the file and 20 poses: ~0.3 s of CPU
def test_pinocchio_reads_the_calibrated_urdf_as_the_calibrated_tree(
    exported: tuple[str, RobotTree, np.ndarray, Any],
) -> None:
    pin: Any = pytest.importorskip("pinocchio", reason="Pinocchio is not installed (`pip install pin`, the dev extra)")
    _, tree, truth, calibration = exported
    q = tree_joint_samples(tree, SAMPLES, seed=5)
    frames = pinocchio_tips(pin, calibration.urdf, tree, q)
    to_link = np.linalg.inv(calibration.world_from_base_link)
    for tip in tree.tips:
        ours = tool_poses(tree, tip, q, truth)
        expected = to_link @ _matrices(ours.positions, ours.rotations) @ np.linalg.inv(calibration.tip_to_tcp[tip])
        assert np.abs(frames[tip][:, :3, 3] - expected[:, :3, 3]).max() < 1e-6  # mm
        assert np.abs(frames[tip][:, :3, :3] - expected[:, :3, :3]).max() < 1e-9


def _row(row: FrameRow) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", [row.roll_deg, row.pitch_deg, row.yaw_deg], degrees=True).as_matrix()
    t[:3, 3] = row.x_mm, row.y_mm, row.z_mm
    return t


def _rot(axis: str, deg: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler(axis, deg, degrees=True).as_matrix()
    return np.asarray(t, dtype=float)


def _shift(axis: int, mm: float) -> np.ndarray:
    t = np.eye(4)
    t[axis, 3] = mm
    return t


def _table_fk(table: DhTable, q: np.ndarray) -> np.ndarray:
    """base row · links · tool row from the table's numbers (q in rad and mm, one per moving link)."""
    t, readings = _row(table.base), iter(q)
    for link in table.links:
        reading = next(readings) if link.name is not None else 0.0
        turn = np.degrees(reading) if link.type == "revolute" else 0.0
        lift = reading if link.type == "prismatic" else 0.0
        beta = _rot("y", link.beta_deg or 0.0)
        z = _rot("z", link.theta_deg + turn) @ _shift(2, link.d_mm + lift)
        x = _shift(0, link.a_mm)
        alpha = _rot("x", link.alpha_deg)
        t = t @ (z @ x @ alpha @ beta if link.convention == "dh" else alpha @ beta @ x @ z)
    out: np.ndarray = t @ _row(table.tool)
    return out


@pytest.mark.slow  # two example trees' FK and 3 x 3 hand-written products: ~0.4 s of CPU
@pytest.mark.parametrize("make", [dual_arm_torso, arm_with_positioner], ids=["torso", "positioner"])
def test_the_branch_tables_compose_to_every_tool(make: Any) -> None:
    tree = make()
    truth = perturbed_tree(tree, seed=6).truth
    tables = branch_dh_tables(tree, truth)
    assert set(tables) == {b.name for b in tree.branches}
    q = tree_joint_samples(tree, 3, seed=7)
    for i in range(q.shape[0]):
        ends: dict[str, np.ndarray] = {}
        at = 0
        for branch in tree.branches:
            own = q[i, at : at + branch.n_joints]
            at += branch.n_joints
            table = tables[branch.name]
            # Where the table starts: its parent's end frame; a mounted branch from the base, the tree's base
            # (its table's base row is the mount); a branch from the base without one, the world (its base row
            # is the tree's base).
            if branch.parent is not None:
                start = ends[branch.parent]
            else:
                start = _row_pose(truth[:6]) if branch.mount is not None else np.eye(4)
            with_tool = start @ _table_fk(table, own)
            ends[branch.name] = with_tool @ np.linalg.inv(_row(table.tool))
            if branch.tool is not None:
                pose = tool_poses(tree, branch.name, q[i : i + 1], truth)
                np.testing.assert_allclose(with_tool[:3, 3], pose.positions[0], atol=1e-9, err_msg=branch.name)
                np.testing.assert_allclose(with_tool[:3, :3], pose.rotations[0], atol=1e-12, err_msg=branch.name)


def _row_pose(p6: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_rotvec(p6[3:6]).as_matrix()
    t[:3, 3] = p6[:3]
    return t


@pytest.mark.slow  # reads the URDF twice: ~0.4 s of CPU
def test_a_urdf_that_is_not_the_trees_is_refused() -> None:
    tree = tree_from_urdf(FIXTURE, "world", ["gripper_l", "gripper_r"])
    other = FIXTURE.replace('name="joint_7_r"', 'name="joint_7_right"').replace("joint_7_r<", "joint_7_right<")
    with pytest.raises(InvalidInput, match="no longer reads as this tree"):
        calibrate_urdf_tree(other, "world", tree, tree.parameters.nominal)
