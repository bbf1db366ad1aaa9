"""The bounds hold against brute force, the exchange ends at a local optimum, augmentation and bad input."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import optimal_design.solve as module
from models import RobotDescription, sample_workspace
from models.errors import InvalidInput, JointOutOfRange, TooFewMeasurements, UnreachablePose
from optimal_design import Criterion, design_poses
from optimal_design.branching import BRANCHED, tighten
from optimal_design.criteria import utility
from optimal_design.exchange import _swap_values_lowrank
from optimal_design.information import candidate_information
from optimal_design.relaxation import relax


@pytest.mark.parametrize("criterion", list(Criterion))
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_bound_holds_for_every_subset(desc: RobotDescription, criterion: Criterion) -> None:
    """13 candidates, K = 10: all 286 subsets enumerated, and none beats the bound."""
    joints = sample_workspace(desc, 13, seed=61)
    design = design_poses(desc, 10, criterion, candidates=joints)
    info = candidate_information(desc, joints, position_only=False)
    best = max(
        utility(criterion, info.subset_information(np.array(s)), info.task)
        for s in itertools.combinations(range(13), 10)
    )
    assert design.bound is not None
    assert best <= design.bound["utility"] + 1e-9 * max(1.0, abs(best))
    mine = utility(criterion, info.subset_information(np.array(design.indices)), info.task)
    assert mine <= best + 1e-9 * max(1.0, abs(best))
    assert design.efficiency is not None and 0 < design.efficiency <= 1 + 1e-12


def test_low_rank_swap_values_match_direct_evaluation(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 40, seed=62)
    info = candidate_information(desc, joints, position_only=False)
    design = np.arange(12)
    pool = np.arange(12, 40)
    base = np.zeros((info.n_params,) * 2)
    for criterion in (Criterion.D, Criterion.A, Criterion.I):
        fast = _swap_values_lowrank(info, criterion, design, base, pool)
        for a, b in [(0, 0), (5, 17), (11, 27)]:
            swapped = design.copy()
            swapped[a] = pool[b]
            direct = utility(criterion, info.subset_information(swapped), info.task)
            assert fast[a, b] == pytest.approx(direct, rel=1e-5)  # M is ill-conditioned with 12 poses


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_exchange_leaves_no_improving_swap(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 80, seed=63)
    design = design_poses(desc, 15, "D", candidates=joints)
    info = candidate_information(desc, joints, position_only=False)
    chosen = np.array(design.indices)
    current = utility(Criterion.D, info.subset_information(chosen), info.task)
    for a in range(chosen.size):
        for j in set(range(80)) - set(chosen.tolist()):
            trial = chosen.copy()
            trial[a] = j
            assert utility(Criterion.D, info.subset_information(trial), info.task) <= current + 1e-9


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_augmentation_keeps_what_was_measured(desc: RobotDescription) -> None:
    measured = sample_workspace(desc, 12, seed=64)
    joints = sample_workspace(desc, 300, seed=65)
    plain = design_poses(desc, 10, "D", candidates=joints)
    augmented = design_poses(desc, 10, "D", candidates=joints, fixed=measured)
    assert augmented.fixed == 12 and len(augmented.indices) == 10
    assert augmented.metrics["log_det"] > plain.metrics["log_det"]
    assert augmented.bound is not None and augmented.metrics["log_det"] <= augmented.bound["value"] + 1e-9
    # Already measured, 12 poses identify everything: even 1 more pose is a valid request.
    assert len(design_poses(desc, 1, "D", candidates=joints, fixed=measured).indices) == 1


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_position_only_designs(desc: RobotDescription) -> None:
    design = design_poses(desc, 25, "D", "position", candidate_count=400, seed=66)
    assert len(design.identifiable) == 51 and design.position_only
    assert design.bound is not None and design.efficiency is not None and design.efficiency > 0.85


def test_bad_input(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 50, seed=67)
    with pytest.raises(InvalidInput, match="between 1 and the number of candidates"):
        design_poses(desc, 60, "D", candidates=joints)
    with pytest.raises(TooFewMeasurements, match="at least 10") as err:
        design_poses(desc, 5, "D", candidates=joints)
    assert err.value.data["needed"] == 10
    with pytest.raises(TooFewMeasurements, match="at least 18"):
        design_poses(desc, 10, "D", "position", candidates=joints)
    with pytest.raises(InvalidInput, match="unknown criterion"):
        design_poses(desc, 10, "G", candidates=joints)
    with pytest.raises(InvalidInput, match="measurement"):
        design_poses(desc, 10, "D", "laser", candidates=joints)
    outside = joints.copy()
    outside[7, 2] = np.radians(190.0)
    with pytest.raises(JointOutOfRange, match="pose 7"):
        design_poses(desc, 10, "D", candidates=outside)
    unassembled = joints.copy()
    unassembled[3, 4:] = [370.0, 550.0, 370.0, 550.0, 370.0, 550.0]
    with pytest.raises(UnreachablePose, match="pose 3"):
        design_poses(desc, 10, "D", candidates=unassembled)


def test_solver_failure_falls_back_to_greedy(desc: RobotDescription, monkeypatch: pytest.MonkeyPatch) -> None:

    def broken(*_args: object, **_kwargs: object) -> object:
        raise np.linalg.LinAlgError("simulated failure")

    monkeypatch.setattr(module, "relax", broken)
    design = design_poses(desc, 12, "D", candidates=sample_workspace(desc, 60, seed=68))
    assert design.bound is None and design.efficiency is None
    assert any("greedy" in n for n in design.notes)
    assert design.metrics["log_det"] > -np.inf


@pytest.mark.parametrize("criterion", BRANCHED)
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_branch_and_bound_tightens_to_the_exact_optimum(desc: RobotDescription, criterion: Criterion) -> None:
    """13 candidates, K = 10: the relaxation's bound is well above the best of the 286 subsets (its integrality
    gap); branch and bound run to the end proves the design optimal, and every bound on the way stays valid."""
    joints = sample_workspace(desc, 13, seed=61)
    info = candidate_information(desc, joints, position_only=False)
    best = max(
        utility(criterion, info.subset_information(np.array(s)), info.task)
        for s in itertools.combinations(range(13), 10)
    )
    tol = 1e-9 * max(1.0, abs(best))
    plain = design_poses(desc, 10, criterion, candidates=joints)
    assert plain.bound is not None and plain.bound["utility"] > best + 1e-3 * abs(best)  # the gap to close
    tightened = design_poses(desc, 10, criterion, candidates=joints, bound_seconds=120.0)
    assert tightened.bound is not None
    proof = tightened.bound["branch_and_bound"]
    # the design changes only if the search found a better one, and then it is the best subset
    assert proof["improved_design"] or tightened.indices == plain.indices
    found = utility(criterion, info.subset_information(np.array(tightened.indices)), info.task)
    assert best - tol <= found <= best + tol
    assert proof["optimal"] and proof["open_leaves"] == 0 and proof["nodes"] > 2
    assert proof["root_utility"] == pytest.approx(plain.bound["utility"], rel=1e-9)
    assert best - tol <= tightened.bound["utility"] <= best + tol
    assert tightened.efficiency == pytest.approx(1.0, abs=1e-8)
    # Stopped early, the bound is still valid and no looser than the root's.
    relaxed = relax(info, criterion, 10, np.zeros((info.n_params,) * 2))
    mine = utility(criterion, info.subset_information(np.array(plain.indices)), info.task)
    for nodes in (2, 6, 20):
        partial = tighten(
            info, criterion, 10, np.zeros((info.n_params,) * 2), relaxed, incumbent=mine, seconds=60.0, max_nodes=nodes
        )
        assert best - tol <= partial.bound <= relaxed.bound + tol  # type: ignore[operator]
        assert partial.nodes <= nodes + 1
