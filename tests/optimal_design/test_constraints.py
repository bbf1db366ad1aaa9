"""Candidate filters (joint sub-ranges, keep-out box) and the minimum spread, with brute-force bounds."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from models import RobotDescription, forward_kinematics, sample_workspace
from models.engine.runtime import runtime_for
from models.errors import InvalidInput
from optimal_design import Criterion, PoseDesign, design_poses, spread_distance
from optimal_design.constraints import platform_centres
from optimal_design.criteria import utility
from optimal_design.information import candidate_information


def _spread(desc: RobotDescription, a: np.ndarray, b: np.ndarray) -> float:
    """The documented metric, written out: RMS over joints of the difference over the range width."""
    width = desc.joint_max - desc.joint_min
    return float(np.sqrt(np.mean(((a - b) / width) ** 2)))


def test_platform_centre_is_the_carriage_frame_applied_to_the_platform(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 20, seed=80)
    fk = forward_kinematics(desc, joints)
    (frames,) = runtime_for(desc).kinematics.batch("carriage_fk", joints[:, : desc.n_chain], desc.parameters.nominal)
    expected = np.einsum("nij,nj->ni", frames[:, :3, :3], fk.platforms[:, :3]) + frames[:, :3, 3]
    tcp, centres = platform_centres(desc, joints)
    np.testing.assert_allclose(centres, expected, atol=1e-9)
    np.testing.assert_allclose(tcp, fk.positions, atol=1e-12)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_joint_sub_ranges_filter_given_candidates(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 300, seed=81)
    lo, hi = float(np.quantile(joints[:, 0], 0.2)), float(np.quantile(joints[:, 0], 0.8))
    design = design_poses(desc, 15, "D", candidates=joints, joint_ranges={0: (lo, hi)})
    inside = (joints[:, 0] >= lo) & (joints[:, 0] <= hi)
    assert design.candidates == int(inside.sum())
    assert design.constraints["excluded"]["joint_ranges"] == int((~inside).sum())
    chosen = joints[list(design.indices)]  # indices point into the candidates as given
    np.testing.assert_allclose(chosen, design.joints)
    assert np.all((chosen[:, 0] >= lo) & (chosen[:, 0] <= hi))
    # sampled candidates are topped up to the count asked for, all inside
    sampled = design_poses(desc, 15, "D", candidate_count=200, seed=3, joint_ranges={0: (lo, hi)})
    assert sampled.candidates == 200
    assert np.all((sampled.joints[:, 0] >= lo) & (sampled.joints[:, 0] <= hi))


def test_keep_out_box_excludes_tcp_and_platform_centre(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 300, seed=82)
    tcp, centres = platform_centres(desc, joints)
    # a box around the median TCP, half the spread on each axis: catches TCPs and some platform centres
    mid, half = np.median(tcp, axis=0), 0.5 * np.std(tcp, axis=0)
    box = (mid - half, mid + half)

    def inside(p: np.ndarray) -> np.ndarray:
        return np.asarray(np.all((p >= box[0]) & (p <= box[1]), axis=1))

    blocked = inside(tcp) | inside(centres)
    assert 0 < blocked.sum() < 250
    design = design_poses(desc, 15, "D", candidates=joints, keep_out=box)
    assert design.candidates == int((~blocked).sum())
    assert not blocked[list(design.indices)].any()
    with pytest.raises(InvalidInput, match="lower corner"):
        design_poses(desc, 15, "D", candidates=joints, keep_out=(mid + half, mid - half))


@pytest.mark.slow  # designs at several spreads: ~8 s here
def test_min_spread_between_chosen_and_fixed_poses(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 200, seed=83)
    measured = sample_workspace(desc, 5, seed=84)
    free = design_poses(desc, 20, "D", candidates=joints, fixed=measured)
    chosen = joints[list(free.indices)]
    closest = min(_spread(desc, a, b) for a, b in itertools.combinations(chosen, 2))
    minimum = 1.05 * closest  # binding: the unconstrained design breaks it
    for criterion in ("D", "I", "E"):
        design = design_poses(desc, 20, criterion, candidates=joints, fixed=measured, min_spread=minimum)
        picked = joints[list(design.indices)]
        for a, b in itertools.combinations(picked, 2):
            assert _spread(desc, a, b) >= minimum
        for a in picked:
            for b in measured:
                assert _spread(desc, a, b) >= minimum
        assert design.constraints["min_spread"] == minimum
    metric = spread_distance(desc, chosen[:1], chosen[1:2])[0, 0]
    np.testing.assert_allclose(metric, _spread(desc, chosen[0], chosen[1]))
    with pytest.raises(InvalidInput, match=r"only \d+ of the candidates fit"):
        design_poses(desc, 20, "D", candidates=joints, min_spread=0.9)


@pytest.mark.parametrize("criterion", list(Criterion))
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_bound_holds_under_constraints_by_brute_force(desc: RobotDescription, criterion: Criterion) -> None:
    """16 candidates, a joint sub-range leaves some, K = 10 with a min spread: every feasible subset is below the
    bound, and the design is feasible and no better than the best feasible subset."""
    joints = sample_workspace(desc, 16, seed=85)
    lo = float(np.sort(joints[:, 1])[2])  # drops the two lowest on joint 1
    keep = np.flatnonzero(joints[:, 1] >= lo)
    kept = joints[keep]
    d = spread_distance(desc, kept, kept)
    minimum = float(np.quantile(d[np.triu_indices(keep.size, 1)], 0.05))
    design = design_poses(desc, 10, criterion, candidates=joints, joint_ranges={1: (lo, 1e9)}, min_spread=minimum)
    info = candidate_information(desc, kept, position_only=False)
    feasible = [
        s
        for s in itertools.combinations(range(keep.size), 10)
        if all(d[a, b] >= minimum for a, b in itertools.combinations(s, 2))
    ]
    assert feasible
    best = max(utility(criterion, info.subset_information(np.array(s)), info.task) for s in feasible)
    assert design.bound is not None
    assert best <= design.bound["utility"] + 1e-9 * max(1.0, abs(best))
    local = np.searchsorted(keep, np.array(design.indices))
    assert np.array_equal(keep[local], np.array(design.indices))
    assert all(d[a, b] >= minimum for a, b in itertools.combinations(local, 2))
    mine = utility(criterion, info.subset_information(local), info.task)
    assert mine <= best + 1e-9 * max(1.0, abs(best))


@pytest.mark.slow  # three condition designs with and without the floor: ~17 s here
def test_d_efficiency_floor_for_the_condition_design(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 300, seed=86)
    plain = design_poses(desc, 20, "condition", candidates=joints, d_efficiency_floor=0)
    floored = design_poses(desc, 20, "condition", candidates=joints, d_efficiency_floor=0.9)
    d = design_poses(desc, 20, "D", candidates=joints)
    assert d.bound is not None and floored.bound is not None and plain.bound is not None
    # independently: log det of the chosen poses against the certified D bound
    info = candidate_information(desc, joints, position_only=False)
    log_det = float(np.linalg.slogdet(info.subset_information(np.array(floored.indices)))[1])
    assert np.exp((log_det - d.bound["utility"]) / info.n_params) >= 0.9 - 1e-12
    assert floored.metrics["condition_number"] >= plain.bound["value"] - 1e-9  # the bound still holds
    assert floored.metrics["log_det"] >= plain.metrics["log_det"]
    with pytest.raises(InvalidInput, match="E and condition"):
        design_poses(desc, 20, "I", candidates=joints, d_efficiency_floor=0.9)
    with pytest.raises(InvalidInput, match="above what the D design reaches"):
        design_poses(desc, 20, "condition", candidates=joints, d_efficiency_floor=0.9999)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_condition_design_keeps_d_efficiency_by_default(desc: RobotDescription) -> None:
    """Omitted, the condition design's floor is 0.9 (soft: lowered to what the D design reaches); 0 turns it off."""
    joints = sample_workspace(desc, 300, seed=86)
    info = candidate_information(desc, joints, position_only=False)
    d = design_poses(desc, 20, "D", candidates=joints)
    assert d.bound is not None

    def d_efficiency(design: PoseDesign) -> float:
        log_det = float(np.linalg.slogdet(info.subset_information(np.array(design.indices)))[1])
        return float(np.exp((log_det - d.bound["utility"]) / info.n_params))  # type: ignore[index]

    default = design_poses(desc, 20, "condition", candidates=joints)
    explicit = design_poses(desc, 20, "condition", candidates=joints, d_efficiency_floor=0.9)
    off = design_poses(desc, 20, "condition", candidates=joints, d_efficiency_floor=0)
    assert default.indices == explicit.indices and default.constraints["d_efficiency_floor"] == 0.9
    assert d_efficiency(default) >= 0.9 - 1e-12
    assert off.constraints["d_efficiency_floor"] == 0 and d_efficiency(off) < 0.9  # what the floor is for
    assert off.metrics["condition_number"] <= default.metrics["condition_number"] + 1e-9
    # 14 candidates, K = 10: the D design reaches 0.81 of its bound; the default floor follows it down
    few = sample_workspace(desc, 14, seed=87)
    small_d = design_poses(desc, 10, "D", candidates=few)
    assert small_d.efficiency is not None and small_d.efficiency < 0.9
    small = design_poses(desc, 10, "condition", candidates=few)
    applied = small.constraints["d_efficiency_floor"]
    # 1e-8: the floor is the log det of the same subset summed in another order (base + blocks), not the same bits
    assert 0 < applied <= small_d.efficiency + 1e-8 and any("default D-efficiency floor" in n for n in small.notes)
    small_info = candidate_information(desc, few, position_only=False)
    assert small_d.bound is not None
    log_det = float(np.linalg.slogdet(small_info.subset_information(np.array(small.indices)))[1])
    assert np.exp((log_det - small_d.bound["utility"]) / small_info.n_params) >= applied - 1e-8
    with pytest.raises(InvalidInput, match="above what the D design reaches"):
        design_poses(desc, 10, "condition", candidates=few, d_efficiency_floor=0.9)
