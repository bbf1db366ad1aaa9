"""Targets given relative to another branch (the torch in the positioner's part frame, the left hand in the right
hand's): the arm's compensated joints put the tool on them on the perturbed simulated truth, checked through
the hand-written numpy model of the trees (tests/models/tree_reference.py), where the program's own joints
miss them by millimetres."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.compensation.poses import pose_matrices
from models.description.examples import UR5_DH
from models.description.structure import description_from_document
from models.errors import InvalidInput, WrongShape
from models.tree import Branch, RobotTree, perturbed_tree, relative_poses, tool_poses, tree_joint_samples
from models.tree.compensation import compensate_relative, compensate_world
from models.tree.examples import TORCH, arm_with_positioner, dual_arm_torso
from tests.models.tree_reference import POSITIONER, TORSO, Segment, chain_fk, relative

TARGETS = 12


def _away_from_singularities(tree: RobotTree, arm: str) -> np.ndarray:
    """Joint vectors where the arm's Jacobian wrt its own joints (central differences of the nominal tool pose,
    rotations as 500 mm lever arms) has its smallest singular value above 150 mm/rad: near a singular
    configuration a compensation of millimetres turns joints by degrees or finds no solution next to the
    program's (the chain's compensation says so, and so does this one)."""
    q = tree_joint_samples(tree, 200, seed=22, margin=0.1)
    own = tree.selection(arm).joints[-6:]
    h = 1e-6
    columns = []
    for j in own:
        plus, minus = q.copy(), q.copy()
        plus[:, j] += h
        minus[:, j] -= h
        hi, lo = tool_poses(tree, arm, plus, check_ranges=False), tool_poses(tree, arm, minus, check_ranges=False)
        turn = Rotation.from_matrix(hi.rotations @ np.swapaxes(lo.rotations, 1, 2)).as_rotvec()
        columns.append(np.hstack([hi.positions - lo.positions, 500.0 * turn]) / (2 * h))
    smallest = np.linalg.svd(np.stack(columns, axis=2), compute_uv=False)[:, -1]
    return q[smallest > 150.0][:TARGETS]


@pytest.mark.slow  # the arm's Newton compensation of 12 targets and its compiled Functions: ~0.5 s of CPU
@pytest.mark.parametrize(
    ("make", "segments", "pair", "moved"),
    [
        (arm_with_positioner, POSITIONER, ("arm", "positioner"), tuple(range(6))),
        # The waist both arms turn on is set by the program: only the left arm's joints are solved.
        (dual_arm_torso, TORSO, ("left", "right"), tuple(range(1, 7))),
    ],
    ids=["torch-on-part", "left-in-right"],
)
def test_the_true_tree_reaches_relative_targets_with_the_compensated_joints(
    make: Callable[[], RobotTree], segments: dict[str, list[Segment]], pair: tuple[str, str], moved: tuple[int, ...]
) -> None:
    tree = make()
    sim = perturbed_tree(tree, seed=21)
    q = _away_from_singularities(tree, pair[0])
    assert q.shape[0] == TARGETS
    taught = relative_poses(tree, *pair, q)  # the program, taught on the nominal tree
    targets = pose_matrices(taught.positions, taught.rotations)

    def reached(joints: np.ndarray) -> np.ndarray:
        """The true tool in the true frame tool, by the numpy model."""
        tool, frame = (chain_fk(segments[name], sim.truth, joints) for name in pair)
        return relative(tool, frame)

    before = np.linalg.norm(reached(q)[:, :3, 3] - targets[:, :3, 3], axis=1)
    assert before.min() > 0.5  # mm: uncompensated, every target is missed

    comp = compensate_relative(tree, sim.truth, pair, q, targets)
    assert comp.reached.all(), comp.reasons
    assert comp.moved == moved
    others = [j for j in range(tree.n_joints) if j not in moved]
    np.testing.assert_array_equal(comp.joints[:, others], q[:, others])  # the positioner, the waist: as given
    assert np.abs(comp.joints - q).max() < np.radians(5.0)  # the program's configuration, a small correction
    after = reached(comp.joints)
    assert np.linalg.norm(after[:, :3, 3] - targets[:, :3, 3], axis=1).max() < 1e-3  # mm
    turn = Rotation.from_matrix(after[:, :3, :3] @ np.swapaxes(targets[:, :3, :3], 1, 2)).magnitude()
    assert turn.max() < 1e-8  # rad


def test_targets_must_be_one_pose_per_joint_vector() -> None:
    tree = arm_with_positioner()
    q = tree_joint_samples(tree, 3, seed=1)
    with pytest.raises(WrongShape, match="3 finite 4 x 4 poses"):
        compensate_relative(tree, tree.parameters.nominal, ("arm", "positioner"), q, np.tile(np.eye(4), (2, 1, 1)))


@pytest.mark.slow  # the left arm's rest-of-chain Functions and Newton on 12 targets: ~0.4 s of CPU
def test_world_targets_move_only_the_tools_own_branches_and_reach_the_true_tree() -> None:
    """A world target of the torso's left hand: the waist carries the right hand too, so it is held as the program
    sets it; the left arm's six joints put the true hand on the target (the numpy model), where the program's
    joints miss it by millimetres."""
    tree = dual_arm_torso()
    sim = perturbed_tree(tree, seed=23)
    q = _away_from_singularities(tree, "left")
    # The program: taught on the nominal tree placed where the instrument sees the real one (world targets are
    # in the instrument's frame, as a chain's compensation promises the nominal geometry on the calibrated base).
    placed = tree.parameters.nominal.copy()
    placed[:6] = sim.truth[:6]
    taught = tool_poses(tree, "left", q, placed)
    targets = pose_matrices(taught.positions, taught.rotations)
    before = chain_fk(TORSO["left"], sim.truth, q)
    assert np.linalg.norm(before[:, :3, 3] - targets[:, :3, 3], axis=1).min() > 0.5
    comp = compensate_world(tree, sim.truth, "left", q, targets)
    assert comp.reached.all(), comp.reasons
    assert comp.moved == tuple(range(1, 7))
    np.testing.assert_array_equal(comp.joints[:, [0, *range(7, 13)]], q[:, [0, *range(7, 13)]])
    after = chain_fk(TORSO["left"], sim.truth, comp.joints)
    assert np.linalg.norm(after[:, :3, 3] - targets[:, :3, 3], axis=1).max() < 1e-3  # mm
    # The positioner's arm shares nothing: its whole chain moves, the base included in the world target.
    cell = arm_with_positioner()
    at = tool_poses(cell, "arm", q[:1, :8])
    alone = compensate_world(cell, cell.parameters.nominal, "arm", q[:1, :8], pose_matrices(at.positions, at.rotations))
    assert alone.moved == tuple(range(6)) and alone.reached.all()
    np.testing.assert_allclose(alone.joints, q[:1, :8], atol=1e-9)  # the nominal tree: the program's joints


def _narrow_cell() -> RobotTree:
    """The arm and positioner cell with the arm's shoulder (q2) limited to ±170°: a range Newton can stop at."""
    links = [dict(row) for row in UR5_DH]
    links[1]["range"] = [-170.0, 170.0]
    desc = description_from_document({"stages": [{"kind": "serial", "convention": "dh", "links": links}]})
    cell = arm_with_positioner()
    arm = Branch("arm", desc.stages, tool=TORCH)
    return RobotTree("narrow", (arm, cell.branches[1]))


def test_a_target_past_a_joints_limit_is_refused_naming_the_joint() -> None:
    tree = _narrow_cell()
    q = tree_joint_samples(tree, 2, seed=4, margin=0.1)
    q[:, 1] = np.radians(169.8)
    past = q.copy()
    past[:, 1] = np.radians(170.4)  # the target: where the arm would be past its limit
    at = tool_poses(tree, "arm", past, check_ranges=False)
    comp = compensate_world(tree, tree.parameters.nominal, "arm", q, pose_matrices(at.positions, at.rotations))
    assert not comp.reached.any()
    for reason in comp.reasons:
        assert reason is not None and "joint arm.q2 at 170.4 deg, outside its range [-170, 170] deg" in reason, reason
    np.testing.assert_array_equal(comp.joints, q)  # refused: the program's joints, as given


def test_a_tool_without_a_joint_of_its_own_is_refused() -> None:
    # A fixture on the waist's end, beside the two arms: every joint on its path also carries the arms.
    torso = dual_arm_torso()
    fixture = Branch("fixture", (), parent="waist", mount=(0.0, 0.0, 500.0, 0.0, 0.0, 0.0), tool=TORCH)
    tree = RobotTree("with-fixture", (*torso.branches, fixture))
    q = tree_joint_samples(tree, 1, seed=1)
    with pytest.raises(InvalidInput, match="no joint of its own"):
        compensate_world(tree, tree.parameters.nominal, "fixture", q, np.eye(4)[None])
