"""The E and condition exchange's swap values: the best swap is the exhaustive evaluation's."""

from __future__ import annotations

import numpy as np
import pytest

from models import RobotDescription, sample_workspace
from optimal_design.criteria import Criterion
from optimal_design.exchange import _swap_values_spectral
from optimal_design.information import candidate_information


def _exhaustive(info, criterion: Criterion, design, pool) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Every swapped design's information matrix decomposed in full: the truth the pruned evaluation must match."""
    out = np.empty((design.size, pool.size))
    for a in range(design.size):
        for b, j in enumerate(pool):
            swapped = design.copy()
            swapped[a] = j
            ev = np.linalg.eigvalsh(info.subset_information(swapped))
            out[a, b] = ev[0] if criterion is Criterion.E else (-np.sqrt(ev[-1] / ev[0]) if ev[0] > 0 else -np.inf)
    return out


@pytest.mark.parametrize("criterion", [Criterion.E, Criterion.CONDITION])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_the_best_swap_is_the_exhaustive_one_also_with_swaps_excluded(
    desc: RobotDescription, criterion: Criterion
) -> None:
    info = candidate_information(desc, sample_workspace(desc, 160, seed=31), position_only=False)
    rng = np.random.default_rng(5)
    base = np.zeros((info.n_params, info.n_params))
    for trial in range(4):
        picked = rng.permutation(info.size)
        design, pool = picked[:20], picked[20:68]
        truth = _exhaustive(info, criterion, design, pool)
        admissible = None if trial % 2 == 0 else rng.random(truth.shape) > 0.3
        expected = truth if admissible is None else np.where(admissible, truth, -np.inf)
        got = _swap_values_spectral(info, criterion, design, base, pool, admissible=admissible)
        a, b = np.unravel_index(int(np.argmax(got)), got.shape)
        # 1e-6: M − FₐᵀFₐ + BⱼᵀBⱼ and the subset summed afresh differ in the last digits of a small eigenvalue
        assert got[a, b] == pytest.approx(expected.max(), rel=1e-6)
        assert expected[a, b] == pytest.approx(expected.max(), rel=1e-6)
        evaluated = np.isfinite(got)
        assert np.allclose(got[evaluated], expected[evaluated], rtol=1e-6)  # exact where evaluated
        assert evaluated.sum() < expected.size  # and the bounds spared some (the point of them)
