"""The pieces behind the tightened D certificate, each against an independent truth: the exact capped scaling
against bisection, the Newton leaf certificates against brute force over every subset a leaf holds, and the
branching choice against the leaves' own children."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from models import RobotDescription, sample_workspace
from optimal_design.branching import _branch_on, _Leaf, _solve, tighten
from optimal_design.criteria import Criterion, utility
from optimal_design.information import CandidateInformation, candidate_information
from optimal_design.relaxation import _capped_bisection, _project, capped, first_order, newton_d, relax


def test_capped_matches_bisection_and_its_own_definition() -> None:
    """min(1, c·v) summing to the total, for one c: the sort-based scaling agrees with bisection to 1e-9."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        n = int(rng.integers(3, 200))
        total = float(rng.integers(1, n))
        v = rng.exponential(size=n) ** rng.uniform(0.5, 6.0)
        v[rng.random(n) < 0.3] = 0.0
        if np.count_nonzero(v) < total:
            continue
        w = capped(v, total)
        assert w.sum() == pytest.approx(total, abs=1e-9)
        assert w.max() <= 1.0 + 1e-15 and w.min() >= 0.0
        below = (w < 1.0 - 1e-12) & (v > 0)
        if below.any():  # the uncapped weights are one multiple of their values, the capped ones at least as far
            c = w[below] / v[below]
            assert np.ptp(c) <= 1e-9 * c.max()
            assert np.all(c.max() * v[w >= 1.0 - 1e-12] >= 1.0 - 1e-9)
        assert np.max(np.abs(w - _capped_bisection(v, total))) < 1e-9


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_projection_onto_the_capped_simplex_is_the_nearest_point() -> None:
    """clip(v − θ, 0, 1) summing to the total, against a 200-step bisection on θ, ties and integer totals too;
    and no other feasible point is nearer (random feasible points, Euclidean distance)."""
    rng = np.random.default_rng(4)
    for trial in range(400):
        n = int(rng.integers(2, 120))
        total = float(rng.integers(1, n)) if trial % 2 else float(rng.uniform(0.5, n - 0.5))
        v = rng.normal(size=n) * rng.uniform(0.01, 3.0)
        if trial % 3 == 0:
            v = np.round(v, 1)  # ties among the breakpoints
        w = _project(v, total)
        assert w.sum() == pytest.approx(total, abs=1e-9) and w.min() >= 0.0 and w.max() <= 1.0
        lo, hi = float(v.min()) - 1.0, float(v.max())
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if np.clip(v - mid, 0.0, 1.0).sum() > total else (lo, mid)
        assert np.max(np.abs(w - np.clip(v - hi, 0.0, 1.0))) < 1e-9
        other = capped(rng.random(n) + 1e-3, total)
        assert np.linalg.norm(v - w) <= np.linalg.norm(v - other) + 1e-12


def _leaf_best(info: CandidateInformation, count: int, fixed_in: tuple[int, ...], fixed_out: tuple[int, ...]) -> float:
    rest = [i for i in range(info.size) if i not in fixed_in and i not in fixed_out]
    best = -np.inf
    for s in itertools.combinations(rest, count - len(fixed_in)):
        chosen = np.array((*fixed_in, *s))
        best = max(best, utility(Criterion.D, info.subset_information(chosen), info.task))
    return best


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_newton_leaf_bounds_hold_for_every_subset_of_the_leaf(desc: RobotDescription) -> None:
    """16 candidates, K = 10 (8 008 subsets): at the root and at leaves fixing candidates in and out, the Newton
    certificate is at least the best subset the leaf holds, and within the multiplicative algorithm's gap of
    its bound (the continuous optimum, which both bound from above)."""
    joints = sample_workspace(desc, 16, seed=71)
    info = candidate_information(desc, joints, position_only=False)
    base = np.zeros((info.n_params,) * 2)
    root = first_order(info, Criterion.D, 10, base)
    polished = newton_d(info, 10, base, root.weights)
    assert polished is not None and polished.bound is not None and root.bound is not None
    best = _leaf_best(info, 10, (), ())
    assert best <= polished.bound + 1e-9 * abs(best)
    assert polished.bound <= root.bound + 1e-4  # Newton's gap is 1e-4, the multiplicative one's up to 0.01
    assert root.bound - best > 0.1  # the integrality gap the leaves below have to close
    rng = np.random.default_rng(72)
    newton_used = 0
    for _ in range(8):
        order = rng.permutation(16)
        fixed_in = tuple(int(i) for i in order[: rng.integers(0, 4)])
        fixed_out = tuple(int(i) for i in order[4 : 4 + rng.integers(0, 4)])
        bound, weights, exact = _solve(info, Criterion.D, 10, base, (fixed_in, fixed_out), parent=root.weights)
        truth = _leaf_best(info, 10, fixed_in, fixed_out)
        assert not exact
        assert truth <= bound + 1e-9 * abs(truth)
        assert np.all(weights[list(fixed_in)] == 1.0) and np.all(weights[list(fixed_out)] == 0.0)
        assert weights.sum() == pytest.approx(10.0, abs=1e-9)
        keep = np.setdiff1d(np.arange(16), fixed_in + fixed_out)
        sub = CandidateInformation(
            joints=info.joints[keep], blocks=info.blocks[keep], free=info.free, task=info.task, position_only=False
        )
        known = base + info.subset_information(np.array(fixed_in, dtype=int))
        mult = first_order(sub, Criterion.D, 10 - len(fixed_in), known)
        assert mult.bound is not None and bound <= mult.bound + 1e-4
        newton_used += newton_d(sub, 10 - len(fixed_in), known, root.weights[keep]) is not None
    assert newton_used >= 6  # the leaves' bounds are Newton's, not the fallback's


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_branching_picks_a_fractional_candidate_whose_children_both_fall(desc: RobotDescription) -> None:
    """The quadratic model's choice is fractional, and both of its children's bounds (solved) are below the
    parent's; its children fall at least as far as those of the most fractional candidate on this problem
    (worst child: what best-first branch and bound has to lower)."""
    joints = sample_workspace(desc, 40, seed=73)
    info = candidate_information(desc, joints, position_only=False)
    base = np.zeros((info.n_params,) * 2)
    root = relax(info, Criterion.D, 12, base)
    assert root.bound is not None
    leaf = _Leaf(-root.bound, 0, (), (), root.weights)
    j = _branch_on(info, Criterion.D, base, leaf, np.arange(info.size))
    assert 1e-4 < root.weights[j] < 1 - 1e-4

    def worst_child(k: int) -> float:
        children = (((k,), ()), ((), (k,)))
        return max(_solve(info, Criterion.D, 12, base, fixed, parent=root.weights)[0] for fixed in children)

    half = int(np.argmin(np.abs(root.weights - 0.5)))
    assert worst_child(j) < root.bound
    assert worst_child(j) <= worst_child(half) + 1e-6


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_tighten_with_newton_leaves_is_monotone_and_valid(desc: RobotDescription) -> None:
    """14 candidates, K = 10: every budget's bound lies between the best subset and the root's, and it falls
    (weakly) as the node budget grows, down to the optimum when the search closes."""
    joints = sample_workspace(desc, 14, seed=74)
    info = candidate_information(desc, joints, position_only=False)
    base = np.zeros((info.n_params,) * 2)
    best = _leaf_best(info, 10, (), ())
    root = relax(info, Criterion.D, 10, base)
    assert root.bound is not None
    previous = root.bound
    for nodes in (2, 8, 32, 10_000):
        result = tighten(info, Criterion.D, 10, base, root, incumbent=best - 1.0, seconds=120.0, max_nodes=nodes)
        assert best - 1e-9 * abs(best) <= result.bound <= previous + 1e-12
        previous = result.bound
    assert result.closed and result.bound == pytest.approx(best, abs=1e-8)
    assert result.better is not None
    found = utility(Criterion.D, info.subset_information(np.sort(result.better)), info.task)
    assert found == pytest.approx(best, abs=1e-8)
