"""A tree's FK, absolute and relative, against a hand-written numpy model, and its Jacobians wrt the global
parameters against central finite differences; the global layout and the refusals of bad input."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from models.errors import InvalidInput, JointOutOfRange, NonFiniteValue, WrongShape
from models.tree import Branch, RobotTree, relative_poses, tool_poses, tree_joint_samples
from models.tree.examples import TORCH, arm_with_positioner, dual_arm_torso
from tests.models.tree_reference import POSITIONER, POSITIONER_NAMES, TORSO, TORSO_NAMES, chain_fk, relative

CASES = [
    (dual_arm_torso, TORSO, TORSO_NAMES, ("left", "right")),
    (arm_with_positioner, POSITIONER, POSITIONER_NAMES, ("arm", "positioner")),
]


@pytest.mark.parametrize(("make", "segments", "names", "pair"), CASES, ids=["torso", "positioner"])
def test_every_tool_and_the_relative_pose_equal_the_numpy_model(make, segments, names, pair) -> None:  # type: ignore[no-untyped-def]
    tree = make()
    assert {i: tree.parameters.names[i] for i in names} == names  # the hand-written layout is the tree's
    rng = np.random.default_rng(3)
    theta = tree.parameters.nominal + rng.uniform(-1, 1, tree.n_params) * tree.parameters.scales * 5
    q = tree_joint_samples(tree, 6, seed=4)
    reference = {tip: chain_fk(segments[tip], theta, q) for tip in tree.tips}
    for tip in tree.tips:
        ours = tool_poses(tree, tip, q, theta)
        np.testing.assert_allclose(ours.positions, reference[tip][:, :3, 3], atol=1e-9)
        np.testing.assert_allclose(ours.rotations, reference[tip][:, :3, :3], atol=1e-12)
    a, b = pair
    rel = relative_poses(tree, a, b, q, theta)
    expected = relative(reference[a], reference[b])
    np.testing.assert_allclose(rel.positions, expected[:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(rel.rotations, expected[:, :3, :3], atol=1e-12)


def _finite_differences(tree: RobotTree, pose, theta: np.ndarray, step: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    """(N, 6, n_params) central differences of (position; rotation as a world-frame small angle)."""
    cols = []
    for k in range(tree.n_params):
        plus, minus = theta.copy(), theta.copy()
        plus[k] += step[k]
        minus[k] -= step[k]
        hi, lo = pose(plus), pose(minus)
        dp = (hi.positions - lo.positions) / (2 * step[k])
        dw = Rotation.from_matrix(hi.rotations @ np.swapaxes(lo.rotations, 1, 2)).as_rotvec() / (2 * step[k])
        cols.append(np.concatenate([dp, dw], axis=1))
    return np.stack(cols, axis=2)


@pytest.mark.parametrize(("make", "pair"), [(c[0], c[3]) for c in CASES], ids=["torso", "positioner"])
def test_jacobians_wrt_the_global_parameters_equal_finite_differences(make, pair) -> None:  # type: ignore[no-untyped-def]
    tree = make()
    theta = tree.parameters.nominal
    q = tree_joint_samples(tree, 3, seed=5)
    step = tree.parameters.scales * 1e-3
    a, b = pair
    for name, pose in (
        (a, lambda t: tool_poses(tree, a, q, t)),
        (b, lambda t: tool_poses(tree, b, q, t)),
        (f"{a}/{b}", lambda t: relative_poses(tree, a, b, q, t)),
    ):
        exact = (
            tool_poses(tree, name, q, theta, jacobian=True)
            if "/" not in name
            else relative_poses(tree, a, b, q, theta, jacobian=True)
        ).jacobians
        assert exact is not None
        numeric = _finite_differences(tree, pose, theta, step)
        # Columns scaled by the tolerances: mm (and rad) per expected error, all of one size.
        scale = tree.parameters.scales
        np.testing.assert_allclose(exact * scale, numeric * scale, atol=1e-7, err_msg=name)


def test_a_shared_waist_is_one_joint_and_one_set_of_parameters_of_both_arms() -> None:
    tree = dual_arm_torso()
    left, right = tree.selection("left"), tree.selection("right")
    assert left.joints[0] == right.joints[0] == 0  # the waist: one column of the global joints
    shared = sorted(set(left.params) & set(right.params))
    assert [tree.parameters.names[i] for i in shared] == [
        "base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz",
        "waist.link1.theta", "waist.link1.d", "waist.link1.a", "waist.link1.alpha",
    ]  # fmt: skip
    for tip in tree.tips:
        np.testing.assert_array_equal(
            tree.chain(tip).parameters.nominal, tree.parameters.nominal[tree.selection(tip).params]
        )
    # Both arms have the same structure: one runtime (one build) serves both chains.
    assert tree.chain("left").structure == tree.chain("right").structure
    # Turning the waist moves both tools, the relative pose not at all.
    q = tree_joint_samples(tree, 2, seed=1)
    turned = q.copy()
    turned[:, 0] += 0.3
    moved = tool_poses(tree, "left", turned).positions - tool_poses(tree, "left", q).positions
    assert np.all(np.linalg.norm(moved, axis=1) > 10.0)
    np.testing.assert_allclose(
        relative_poses(tree, "left", "right", turned).positions,
        relative_poses(tree, "left", "right", q).positions,
        atol=1e-9,
    )


def test_bad_input_names_what_to_fix() -> None:
    tree = dual_arm_torso()
    q = tree_joint_samples(tree, 2, seed=1)
    with pytest.raises(InvalidInput, match=r"no branch 'head'.*\['waist', 'left', 'right'\]"):
        tool_poses(tree, "head", q)
    with pytest.raises(InvalidInput, match=r"branch 'waist' has no tool; the tree's tools are \['left', 'right'\]"):
        tool_poses(tree, "waist", q)
    assert tree.joint_index("right.q2", "joints") == 8  # the waist's one joint, the left arm's six, then right.q1
    with pytest.raises(InvalidInput, match=r"ranges.q9: the tree has no joint 'q9'; its joints are \['waist.q1'") as e:
        tree.joint_index("q9", "ranges.q9")
    assert (e.value.field, e.value.value, e.value.allowed) == ("ranges.q9", "q9", list(tree.joint_names))
    with pytest.raises(WrongShape, match="13 numbers"):
        tool_poses(tree, "left", q[:, :7])
    q[1, 8] = np.radians(200.0)
    with pytest.raises(JointOutOfRange, match=r"pose 1: joint right.q2 = 200 deg"):
        tool_poses(tree, "left", q)
    q[0, 2] = np.nan
    with pytest.raises(NonFiniteValue, match=r"pose 0: joint \S+ is nan, not a finite number"):
        tool_poses(tree, "left", q)
    with pytest.raises(InvalidInput, match=r"fixed\[3\]: a tool measured in its own frame says nothing") as caught:
        tree.check_record("left", "left", "fixed[3]")
    assert caught.value.field == "fixed[3].frame"
    arm = dual_arm_torso().branches[1]
    with pytest.raises(InvalidInput, match="hangs from 'waist', which is not a branch declared before it"):
        RobotTree("t", (arm,))
    with pytest.raises(InvalidInput, match="at least one branch with a tool"):
        RobotTree("t", (Branch("a", arm.stages),))
    with pytest.raises(InvalidInput, match="two branches are named 'a'"):
        RobotTree("t", (Branch("a", arm.stages, tool=TORCH), Branch("a", arm.stages, tool=TORCH)))
