"""Design criteria on the information matrix M = Σ AᵢᵀAᵢ, and the observability indices of a design.

Every criterion is turned into a utility to maximise (`utility`), so that
rounding and exchange treat them alike; `value` is the natural number users
read (log det, trace of the inverse, smallest eigenvalue, condition number of
the stacked scaled Jacobian, predicted RMS TCP error in mm).
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from models._types import Array
from models.errors import InvalidInput


class Criterion(StrEnum):
    D = "D"
    A = "A"
    E = "E"
    CONDITION = "condition"
    I = "I"  # noqa: E741  (the name of the criterion in the literature)

    @classmethod
    def parse(cls, name: str) -> Criterion:
        for c in cls:
            if c.value.lower() == str(name).lower():
                return c
        raise InvalidInput(
            f"unknown criterion {name!r}; choose one of {[c.value for c in cls]}", field="criterion", value=str(name)
        )


def eigenvalues(m: Array) -> Array:
    return np.asarray(np.linalg.eigvalsh((m + m.T) / 2), dtype=float)


def utility(criterion: Criterion, m: Array, task: Array) -> float:
    """Larger is better; -inf for a singular design."""
    ev = eigenvalues(m)
    if ev[0] <= ev[-1] * 1e-14 or ev[0] <= 0:
        return float("-inf")
    if criterion is Criterion.D:
        return float(np.sum(np.log(ev)))
    if criterion is Criterion.E:
        return float(ev[0])
    if criterion is Criterion.CONDITION:
        return -float(np.sqrt(ev[-1] / ev[0]))
    inv = np.linalg.inv(m)
    if criterion is Criterion.A:
        return -float(np.trace(inv))
    return -float(np.trace(task @ inv))


def value(criterion: Criterion, m: Array, task: Array) -> float:
    """The criterion as users read it (see module docstring)."""
    u = utility(criterion, m, task)
    if criterion in (Criterion.D, Criterion.E):
        return u
    if criterion is Criterion.I:
        return float(np.sqrt(-u)) if np.isfinite(u) else float("inf")
    return -u


def metrics(m: Array, rows: int, task: Array) -> dict[str, float]:
    """api.md's metrics and the observability indices O1-O5 of the stacked scaled Jacobian.

    O1 (Borm & Menq) = (σ₁⋯σₚ)^(1/P)/√m, O2 = σ_min/σ_max, O3 = σ_min, O4 (noise amplification,
    Nahvi & Hollerbach) = σ_min²/σ_max, O5 (Sun & Hollerbach) = 1/Σ(1/σᵢ); m = number of measured rows.
    """
    ev = np.clip(eigenvalues(m), 0.0, None)
    sigma = np.sqrt(ev)
    p = sigma.size
    singular = sigma[0] <= sigma[-1] * 1e-7
    inf = float("inf")
    log_det = float(np.sum(np.log(ev))) if not singular else -inf
    inv = np.linalg.inv(m) if not singular else None
    return {
        "condition_number": float(sigma[-1] / sigma[0]) if not singular else inf,
        "log_det": log_det,
        "min_singular_value": float(sigma[0]),
        "max_singular_value": float(sigma[-1]),
        "trace_inverse": float(np.trace(inv)) if inv is not None else inf,
        "predicted_rms_tcp_mm": float(np.sqrt(np.trace(task @ inv))) if inv is not None else inf,
        "O1": float(np.exp(np.mean(np.log(sigma))) / np.sqrt(rows)) if not singular else 0.0,
        "O2": float(sigma[0] / sigma[-1]),
        "O3": float(sigma[0]),
        "O4": float(sigma[0] ** 2 / sigma[-1]),
        "O5": float(1.0 / np.sum(1.0 / sigma)) if not singular else 0.0,
        "parameters": float(p),
    }
