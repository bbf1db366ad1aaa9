"""The E and condition relaxation (a spectral bundle of small compressed SDPs, Clarabel called directly) against
the uncompressed SDP on every candidate, posed independently with cvxpy: its bound is valid and close."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from optimal_design.criteria import D_OPTIMAL, Criterion, utility
from optimal_design.information import CandidateInformation
from optimal_design.relaxation import SUBSPACE_START, first_order, sdp

P, ROWS, CANDIDATES, K = 16, 3, 70, 10


@pytest.fixture(scope="module")
def info() -> CandidateInformation:
    """Random candidates whose parameters' scales span three orders of magnitude (as the scaled Jacobian's
    do), with more parameters than the first round's basis holds: the bases must move to reach the bound."""
    assert P > SUBSPACE_START
    rng = np.random.default_rng(11)
    scales = np.logspace(0, -1.5, P)
    blocks = rng.normal(size=(CANDIDATES, ROWS, P)) * scales
    return CandidateInformation(
        joints=np.zeros((CANDIDATES, 6)),
        blocks=blocks,
        free=tuple(range(P)),
        task=np.eye(P),
        position_only=False,
    )


def _full_sdp(info: CandidateInformation, criterion: Criterion) -> float:
    """The relaxation's optimum, uncompressed on every candidate: max λ_min, or min cond = √(λ_max/λ_min) through
    u = τ·w with I ⪯ ... : max s with M(u) ⪰ s·I, M(u) ⪯ I."""
    f = np.einsum("mri,mrj->mij", info.blocks, info.blocks)
    w = cp.Variable(info.size, nonneg=True)
    m = sum(w[i] * f[i] for i in range(info.size))
    s = cp.Variable()
    if criterion is Criterion.E:
        constraints = [(m + m.T) / 2 - s * np.eye(P) >> 0, cp.sum(w) == K, w <= 1]
        cp.Problem(cp.Maximize(s), constraints).solve(solver=cp.CLARABEL)
        return float(s.value)
    tau = cp.Variable(nonneg=True)
    sym = (m + m.T) / 2
    constraints = [sym - s * np.eye(P) >> 0, np.eye(P) - sym >> 0, cp.sum(w) == K * tau, w <= tau]
    cp.Problem(cp.Maximize(s), constraints).solve(solver=cp.CLARABEL)
    return -float(np.sqrt(1.0 / s.value))  # the utility: −cond


@pytest.mark.parametrize("criterion", [Criterion.E, Criterion.CONDITION])
@pytest.mark.slow  # ~0.5 s (the reference SDP): outside the inner loop (make test-fast)
def test_the_bound_is_valid_and_within_two_percent_of_the_full_sdp(
    info: CandidateInformation, criterion: Criterion
) -> None:
    base = np.zeros((P, P))
    relaxed = sdp(info, criterion, K, base, d_relaxation=first_order(info, D_OPTIMAL, K, base))
    truth = _full_sdp(info, criterion)
    assert relaxed.bound is not None
    tol = 1e-6 * abs(truth)
    assert relaxed.bound >= truth - tol  # no K-subset, and not even the relaxation, beats the bound
    # and close: the moving bases found the optimum's directions (the first round alone is 4-7 % off)
    assert relaxed.bound <= truth + 0.02 * abs(truth)
    # the relaxed weights are feasible, and no better than the optimum
    assert relaxed.weights.sum() == pytest.approx(K, rel=1e-4)
    assert relaxed.weights.min() >= 0 and relaxed.weights.max() <= 1
    assert utility(criterion, info.information(relaxed.weights), info.task) <= truth + tol
