"""The IWR's hybrid stages inside a branch of a tree (issue 47): a 4-axis DH carriage and a Stewart–Gough
hexapod whose platform pose is solved by closure, beside a two-axis positioner on the same floor.

Independent truths: the IWR's own description (`models.description.iwr`) and its own forward kinematics and
identification
(`models.kinematics`, `models.identification.identify`) on the same simulated robot. The tree's IWR tool is the
IWR's chain; calibrated with the positioner's records in one problem, its held-out error is what the IWR alone
calibrated from the same records gets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.description.iwr import IWR_HEXAPOD, IWR_LINKS, iwr
from models.identification import identify
from models.kinematics import forward_kinematics, solve_platforms
from models.noise import NoiseModel
from models.simulation import SimulatedRobot, measure
from models.stages import HexapodStage, SerialStage
from models.tree import (
    Branch,
    RobotTree,
    SimulatedTree,
    identify_tree,
    measure_tree,
    perturbed_tree,
    tool_poses,
    tree_joint_samples,
)
from models.tree.examples import PART, POSITIONER, _serial

TORCH = (30.0, -20.0, 180.0, 0.0, 0.0, 0.0)
"""The IWR's tool off the platform's axis (mm, rotation vector)."""
NOISE = NoiseModel(position_mm=0.02, orientation_rad=math.radians(0.005))
POSES, HELD = 40, 60


def iwr_cell(*, split: bool = False) -> RobotTree:
    """The IWR as one branch (`split`: its carriage a parent branch, the hexapod its child) and a positioner
    1.5 m beside it."""
    positioner = Branch(
        "positioner", (_serial(POSITIONER),), mount=(0.0, 1500.0, 600.0, math.pi / 2, 0.0, 0.0), tool=PART
    )
    iwr_branches: tuple[Branch, ...]
    if split:
        iwr_branches = (
            Branch("carriage", (SerialStage(IWR_LINKS),)),
            Branch("iwr", (HexapodStage(IWR_HEXAPOD),), parent="carriage", tool=TORCH),
        )
    else:
        iwr_branches = (Branch("iwr", (SerialStage(IWR_LINKS), HexapodStage(IWR_HEXAPOD)), tool=TORCH),)
    return RobotTree("iwr-cell", (*iwr_branches, positioner))


DESC = iwr(tool=TORCH)


@pytest.fixture(scope="module")
def tree() -> RobotTree:
    return iwr_cell()


@pytest.mark.parametrize("split", [False, True], ids=["one-branch", "carriage-and-hexapod"])
def test_the_iwr_tool_of_the_tree_is_the_iwr(split: bool) -> None:
    tree = iwr_cell(split=split)
    assert tree.n_joints == DESC.n_joints + 2
    q = tree_joint_samples(tree, 6, seed=3)  # the hexapod's legs from platforms in its workspace: they assemble
    sim = perturbed_tree(tree, seed=4)
    sel = tree.selection("iwr")
    for theta in (tree.parameters.nominal, sim.truth):
        ours = tool_poses(tree, "iwr", q, theta)
        theirs = forward_kinematics(DESC, q[:, sel.joints], theta[sel.params])
        np.testing.assert_allclose(ours.positions, theirs.positions, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ours.rotations, theirs.rotations, rtol=0, atol=1e-12)
    # The chain's parameters are the IWR's, in its order: the tree adds none and leaves none out.
    assert tree.chain("iwr").parameters.names == DESC.parameters.names


def test_the_samples_draw_platforms_in_the_workspace_and_their_legs_assemble(tree: RobotTree) -> None:
    q = tree_joint_samples(tree, 50, seed=5)
    lo, hi = tree.joint_limits
    assert np.all((q >= lo) & (q <= hi))
    # The closure solved from the drawn legs lands on a platform inside the stage's workspace box, with the
    # legs' equations met: each drawn vector is an assembly of the real hexapod, not six independent strokes.
    platforms, closure = solve_platforms(DESC, q[:, tree.selection("iwr").joints], DESC.parameters.nominal)
    assert closure.max() < 1e-6
    wlo, whi = np.array(IWR_HEXAPOD.workspace_min), np.array(IWR_HEXAPOD.workspace_max)
    assert np.all((platforms >= wlo - 1e-6) & (platforms <= whi + 1e-6))
    # The positioner's joints are still the one uniform draw inside its ranges.
    assert q[:, -2:].std(axis=0).min() > 0.3


def _truth_of_iwr(tree: RobotTree, sim: SimulatedTree) -> SimulatedRobot:
    sel = tree.selection("iwr")
    return SimulatedRobot(DESC, DESC.parameters.nominal, sim.truth[sel.params])


@pytest.mark.slow  # two fits of a 90-parameter tree and a 70-parameter chain with a closure: a few s of CPU
def test_calibrated_in_the_tree_the_iwr_is_as_accurate_as_calibrated_alone(tree: RobotTree) -> None:
    sim = perturbed_tree(tree, seed=21)
    q = tree_joint_samples(tree, POSES, seed=22)
    groups = [measure_tree(sim, tip, q, noise=NOISE, seed=k) for k, tip in enumerate(tree.tips)]
    fit = identify_tree(tree, groups, noise=NOISE)
    assert fit.statistics.noise_consistent, fit.statistics.variance_factor

    sel = tree.selection("iwr")
    robot = _truth_of_iwr(tree, sim)
    # The same IWR records, read by the chain's own pipeline.
    alone = identify(DESC, measure(robot, q[:, sel.joints], NOISE, seed=0, position_only=True), noise=NOISE)

    held = tree_joint_samples(tree, HELD, seed=23)

    def rms(tool: str, theta: np.ndarray) -> float:
        ours = tool_poses(tree, tool, held, theta).positions
        truth = tool_poses(tree, tool, held, sim.truth).positions
        return float(np.sqrt(np.mean(np.sum((ours - truth) ** 2, axis=1))))

    in_tree = rms("iwr", fit.parameters)
    truth = forward_kinematics(DESC, held[:, sel.joints], robot.truth).positions
    by_itself = forward_kinematics(DESC, held[:, sel.joints], alone.parameters).positions
    chain_rms = float(np.sqrt(np.mean(np.sum((by_itself - truth) ** 2, axis=1))))
    assert in_tree <= 1.1 * chain_rms  # measured: 0.0210 mm in the tree, 0.0197 mm alone
    assert in_tree < 3 * NOISE.position_mm  # the noise level: 0.02 mm per axis
    assert rms("positioner", fit.parameters) < 3 * NOISE.position_mm
    assert rms("iwr", fit.start) > 20 * in_tree  # the calibration is worth having
