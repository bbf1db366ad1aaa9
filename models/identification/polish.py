"""Gauss–Newton polishing after IPOPT."""

from __future__ import annotations

import numpy as np

from models._types import Array
from models.identification.residuals import FitProblem

POLISH_STEPS = 4
POLISH_DECREMENT = 1e-6
"""Gauss–Newton polishing stops when the next step would lower Σr² by less than this (in σ²)."""


def polish(problem: FitProblem, z: Array, lower: Array, upper: Array) -> tuple[Array, int]:
    """Full Gauss–Newton steps after IPOPT until the next one would lower Σr² by < POLISH_DECREMENT σ².

    IPOPT stops on an absolute gradient test; in a badly conditioned campaign that can leave the weakest
    directions short of the optimum by more than their own uncertainty. The decrement gᵀH⁻¹g is the χ² the next
    step would gain, the test that matters statistically. Skipped when bounds are set (a step may cross one).
    """
    if np.isfinite(lower).any() or np.isfinite(upper).any():
        return z, 0
    z = z.copy()
    steps = 0
    for _ in range(POLISH_STEPS):
        ev = problem.evaluate(z)
        if ev is None:
            break
        try:
            step = np.linalg.solve(ev.hessian, -ev.gradient)
        except np.linalg.LinAlgError:
            break
        if -float(ev.gradient @ step) * ev.residuals.size < POLISH_DECREMENT:
            break
        trial = problem.evaluate(z + step)
        if trial is None or trial.objective > ev.objective * (1 + 1e-12):
            break
        z = z + step
        steps += 1
    return z, steps
