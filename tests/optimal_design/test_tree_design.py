"""Record design over a tree of chains (`optimal_design.tree`): the candidates' rows are exactly the ones
`identify_tree` stacks; on the simulated dual-arm torso and the arm with its two-axis positioner, designed
records beat random ones drawn from the same pool, both in the criterion and in the held-out error of an
identification from records measured on a perturbed truth (each tool, and the relative pose)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from models.engine.runtime import default_registry
from models.errors import InvalidInput, JointOutOfRange
from models.noise import NoiseModel
from models.tree import (
    RobotTree,
    SimulatedTree,
    ToolRecords,
    identify_tree,
    measure_tree,
    perturbed_tree,
    relative_poses,
    tool_poses,
    tree_joint_samples,
)
from models.tree.examples import arm_with_positioner, dual_arm_torso
from models.tree.identification import TreeProblem
from optimal_design.tree import TreeCandidate, design_tree, tree_candidates, tree_information

NOISE = NoiseModel(position_mm=0.02)
POOL = 150
"""Random joint vectors of the tree; each offers both tools' positions and the relative one (450 candidates)."""
RANDOM_DRAWS = 6


def _measured(sim: SimulatedTree, chosen: Sequence[TreeCandidate], seed: int) -> list[ToolRecords]:
    """The chosen records measured on the truth, one group per kind of record."""
    groups: dict[tuple[str, str | None], list[np.ndarray]] = {}
    for c in chosen:
        groups.setdefault((c.tool, c.frame), []).append(c.joints)
    return [
        measure_tree(sim, tool, np.array(rows), frame=frame, noise=NOISE, seed=seed + k)
        for k, ((tool, frame), rows) in enumerate(groups.items())
    ]


def _held_out_rms(tree: RobotTree, theta: np.ndarray, truth: np.ndarray, pair: tuple[str, str]) -> float:
    """RMS position error over both tools and the relative pose at 100 fresh joint vectors, mm."""
    q = tree_joint_samples(tree, 100, seed=99)
    gaps = [
        tool_poses(tree, tip, q, theta, check_ranges=False).positions
        - tool_poses(tree, tip, q, truth, check_ranges=False).positions
        for tip in tree.tips
    ]
    gaps.append(
        relative_poses(tree, *pair, q, theta, check_ranges=False).positions
        - relative_poses(tree, *pair, q, truth, check_ranges=False).positions
    )
    return float(np.sqrt(np.mean(np.sum(np.concatenate(gaps) ** 2, axis=1))))


@pytest.mark.slow  # a design (~0.5 s) and seven identifications of a tree: ~2-3 s of CPU
@pytest.mark.parametrize(
    ("make", "pair", "count", "criterion", "ratio"),
    [
        # Measured (truths 11-13): held-out RMS 0.57-0.58x the random median (D), 0.55-0.68x (I).
        (dual_arm_torso, ("left", "right"), 36, "D", 0.75),
        (arm_with_positioner, ("arm", "positioner"), 20, "I", 0.8),
    ],
    ids=["torso-D", "positioner-I"],
)
def test_designed_records_beat_random_ones_in_criterion_and_held_out_error(
    make: Callable[[], RobotTree], pair: tuple[str, str], count: int, criterion: str, ratio: float
) -> None:
    tree = make()
    pool = tree_candidates(tree, tree_joint_samples(tree, POOL, seed=5), relative=[pair])
    design = design_tree(tree, pool, count, criterion, relative=[pair], noise=NOISE)
    assert len(design.chosen) == count and design.candidates == len(pool)
    assert all(pool[i] is chosen for i, chosen in zip(design.indices, design.chosen, strict=True))
    # The three kinds of record are all worth taking: the relative ones see both branches at once.
    assert {g[0] + ("/" + g[1] if g[1] else "") for g in design.groups()} >= {f"{pair[0]}/{pair[1]}", pair[0]}
    sign = 1.0 if criterion == "D" else -1.0  # log det up, mm down
    assert sign * design.value > sign * design.random_baseline["value"]
    assert design.efficiency is not None and design.efficiency > 0.6  # against the certified bound

    sim = perturbed_tree(tree, seed=11)
    fit = identify_tree(tree, _measured(sim, design.chosen, seed=100), noise=NOISE)
    designed = _held_out_rms(tree, fit.parameters, sim.truth, pair)
    rng = np.random.default_rng(3)
    random = []
    for _ in range(RANDOM_DRAWS):
        pick = rng.choice(len(pool), count, replace=False)
        theirs = identify_tree(tree, _measured(sim, [pool[i] for i in pick], seed=100), noise=NOISE)
        random.append(_held_out_rms(tree, theirs.parameters, sim.truth, pair))
    assert designed < ratio * float(np.median(random)), (designed, sorted(random))
    # What the design predicted is the size of what it got (first order, one draw of the noise).
    assert 0.5 < designed / design.metrics["predicted_rms_tcp_mm"] < 2.0
    predicted = {a.label: a.rms_position_mm for a in design.accuracy}
    random_predicted = {a.label: a.rms_position_mm for a in design.random_accuracy}
    label = f"{pair[0]}/{pair[1]}"
    assert predicted[label] < random_predicted[label]  # the relative pose, what the process needs


@pytest.mark.slow  # an identification's Jacobian and a small design: ~0.5 s of CPU
def test_the_rows_are_the_identifications_and_pose_records_pad_position_ones() -> None:
    tree = arm_with_positioner()
    q = tree_joint_samples(tree, 12, seed=8)
    position = tree_candidates(tree, q[:8], relative=[("arm", "positioner")])
    pose = tree_candidates(tree, q[8:], tools=["arm"], measurement="pose")
    records = [*position, *pose]
    built = tree_information(tree, records, noise=NOISE)
    assert built.info.rows == 6
    assert not built.info.blocks[: len(position), 3:].any()  # position records: three zero rows
    # The same records as identify_tree's groups: its scaled Jacobian (rows in σ, columns in tolerances) gives the
    # same information on the same subset. Measured exactly on the nominal tree, so that the orientation rows'
    # J_l(φ)⁻¹ is the identity the design's first-order rows assume.
    exact, registry = SimulatedTree(tree, tree.parameters.nominal, tree.parameters.nominal), default_registry()
    silent = NoiseModel(position_mm=1e-12, orientation_rad=1e-12)
    groups = [
        measure_tree(exact, c.tool, c.joints[None], frame=c.frame, noise=silent, position_only=c.position_only)
        for c in records
    ]
    problem = TreeProblem(tree, tuple(groups), NOISE, tree.parameters.nominal, np.arange(tree.n_params), registry)
    _, jac = problem.evaluate(tree.parameters.nominal)
    free = list(built.free)
    # The groups' order differs from the candidates'; information is a sum, so the order does not matter.
    information = built.info.subset_information(np.arange(len(records)))
    np.testing.assert_allclose(information, jac[:, free].T @ jac[:, free], rtol=1e-9, atol=1e-6)


def test_bad_records_are_named() -> None:
    tree = arm_with_positioner()
    q = tree_joint_samples(tree, 3, seed=1)
    pool = list(tree_candidates(tree, q))
    with pytest.raises(InvalidInput, match=r"no branch 'torch'") as raised:
        design_tree(tree, [*pool, TreeCandidate("torch", q[0])], 2)
    assert raised.value.field == "candidates[6].tool"
    with pytest.raises(InvalidInput, match="own frame"):
        design_tree(tree, [TreeCandidate("arm", q[0], frame="arm")], 1)
    far = q[0].copy()
    far[1] = np.radians(400.0)
    with pytest.raises(JointOutOfRange, match="pose 1"):
        design_tree(tree, [pool[0], TreeCandidate("arm", far)], 1)
    with pytest.raises(InvalidInput, match="at least one candidate"):
        design_tree(tree, [], 1)
