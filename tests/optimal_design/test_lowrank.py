"""Every swap's D, A and I value from the r × r systems (optimal_design.lowrank) against the swapped design's
information matrix decomposed afresh, and the bounds the exchange prunes with against those values."""

from __future__ import annotations

import numpy as np
import pytest

from optimal_design.criteria import CRITERIA, Criterion, smooth
from optimal_design.exchange import _swap_values_lowrank
from optimal_design.information import CandidateInformation
from optimal_design.lowrank import cholesky, lower_inverse, pair_terms, swap_terms

P, ROWS = 12, 3
SMOOTH = [Criterion.D, Criterion.A, Criterion.I]


def _info(candidates: int, seed: int) -> CandidateInformation:
    """Random candidates; the first P / ROWS of them together are an orthogonal matrix (times 2), so they
    identify every parameter, well conditioned, and without any one of them M is singular."""
    rng = np.random.default_rng(seed)
    blocks = rng.normal(size=(candidates, ROWS, P)) * np.logspace(0, -1, P)
    blocks[: P // ROWS] = 2.0 * np.linalg.qr(rng.normal(size=(P, P)))[0].reshape(P // ROWS, ROWS, P)
    task_rows = rng.normal(size=(20, 3, P))
    return CandidateInformation(
        joints=np.zeros((candidates, 6)),
        blocks=blocks,
        free=tuple(range(P)),
        task=np.einsum("nri,nrj->ij", task_rows, task_rows) / 20,
        position_only=False,
    )


def _direct(info: CandidateInformation, criterion: Criterion, design: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """Each swapped design's utility from its own information matrix."""
    out = np.empty((design.size, pool.size))
    for a in range(design.size):
        for b, j in enumerate(pool):
            swapped = design.copy()
            swapped[a] = j
            out[a, b] = CRITERIA[criterion].utility(info.subset_information(swapped), info.task)
    return out


def test_batched_cholesky_and_triangular_inverse_match_lapack() -> None:
    rng = np.random.default_rng(3)
    a = rng.normal(size=(7, 5, 6, 6))
    spd = a @ a.transpose(0, 1, 3, 2) + 0.1 * np.eye(6)
    factor, ok = cholesky(spd)
    assert ok.all()
    assert np.allclose(factor, np.linalg.cholesky(spd))
    assert np.allclose(lower_inverse(factor), np.linalg.inv(factor))
    indefinite = spd.copy()
    indefinite[2, 3] -= 50 * np.eye(6)
    flags = cholesky(indefinite)[1]
    assert not flags[2, 3] and flags.sum() == flags.size - 1


@pytest.mark.parametrize("criterion", SMOOTH)
def test_swap_values_match_direct_evaluation_even_where_removal_alone_is_singular(criterion: Criterion) -> None:
    """4 poses of 3 rows for 12 parameters: M is full rank and removing any pose leaves it singular, so only the
    add-then-remove order is well posed; 8 poses: the ordinary case."""
    info = _info(30, seed=5)
    crit = smooth(criterion)
    for size in (P // ROWS, 8):
        design, pool = np.arange(size), np.arange(size, 30)
        m = info.subset_information(design)
        truth = _direct(info, criterion, design, pool)
        rectangle = crit.swap_values(info, swap_terms(info.blocks[design], info.blocks[pool], m, np.linalg.inv(m)))
        assert np.all(np.isfinite(rectangle))
        assert np.allclose(rectangle, truth, rtol=1e-8, atol=0)
        rows, cols = np.nonzero(np.ones_like(truth, dtype=bool))
        pairs = pair_terms(info.blocks[design], info.blocks[pool], (rows, cols), m, np.linalg.inv(m))
        assert np.allclose(crit.swap_values(info, pairs), truth[rows, cols], rtol=1e-8, atol=0)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("criterion", SMOOTH)
def test_bounds_hold_and_pruned_evaluation_keeps_every_swap_above_the_threshold(criterion: Criterion) -> None:
    info = _info(215, seed=7)  # a pool over exchange.BOUNDED_POOL: the bounds are used
    crit = smooth(criterion)
    rng = np.random.default_rng(1)
    for _ in range(2):
        picked = rng.permutation(info.size)
        design, pool = np.sort(picked[:8]), picked[8:]
        m = info.subset_information(design)
        truth = _direct(info, criterion, design, pool)
        current = crit.utility(m, info.task)
        for above in (current, float(np.quantile(truth, 0.9))):
            bound = crit.swap_bound(info, design, pool, m=m, above=above)
            assert np.all(bound >= truth - 1e-9 * np.abs(truth).max())  # valid everywhere
            pruned = _swap_values_lowrank(info, criterion, design, np.zeros((P, P)), pool, above=above)
            keep = truth > above + 1e-9 * abs(above)
            assert np.allclose(pruned[keep], truth[keep], rtol=1e-7)  # every swap above the threshold is exact
            assert np.all(pruned[~keep] <= above + 1e-9 * abs(above) + 1e-12)  # and the others stay below it
            assert np.isneginf(pruned).any()  # and the bound spared some


@pytest.mark.parametrize("criterion", SMOOTH)
def test_a_swap_onto_a_singular_design_is_worthless(criterion: Criterion) -> None:
    """4 poses that just identify the 12 parameters, swapped for a candidate with one non-zero row (a ballbar
    length among camera rows, padded with zeros): the swapped design is singular, so its value is −inf however
    rounding leaves the Schur complement's last pivot."""
    info = _info(30, seed=5)
    blocks = info.blocks.copy()
    blocks[20] = 0.0
    blocks[20, 0] = blocks[0, 0]  # what pose 0 measures along its first row, nothing else
    info = CandidateInformation(joints=info.joints, blocks=blocks, free=info.free, task=info.task, position_only=False)
    design, pool = np.arange(P // ROWS), np.array([20])
    m = info.subset_information(design)
    truth = _direct(info, criterion, design, pool)
    assert np.all(np.isneginf(truth))  # every one of these swaps loses rank
    values = smooth(criterion).swap_values(
        info, swap_terms(info.blocks[design], info.blocks[pool], m, np.linalg.inv(m))
    )
    assert np.all(np.isneginf(values))
