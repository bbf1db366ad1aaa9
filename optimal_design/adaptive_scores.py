"""How much one more pose would improve a design: the sequential step of an adaptive campaign.

With `M` the information of the records so far (tolerance units, the identifiable columns: the same scaling as
`optimal_design.information`) and `Aᵢ` a candidate's scaled rows, measuring candidate `i` gives `M + AᵢᵀAᵢ`.
Every score below is exact for that rank-`rows` update (the matrix determinant lemma and Woodbury's identity),
so no candidate's matrix is ever formed or inverted: with `Bᵢ = Aᵢ M⁻¹` and `Sᵢ = I + Bᵢ Aᵢᵀ` (rows × rows),

- D: log det(M + AᵢᵀAᵢ) − log det M = log det Sᵢ;
- I: tr(L M⁻¹) − tr(L (M + AᵢᵀAᵢ)⁻¹) = tr(Sᵢ⁻¹ Bᵢ L Bᵢᵀ), the fall of the predicted mean TCP variance;
- worst: the predicted variance at workspace pose p falls by tr(Cᵢₚᵀ Sᵢ⁻¹ Cᵢₚ), `Cᵢₚ = Bᵢ Rₚᵀ` (Rₚ its scaled
  TCP position rows); the score is minus the largest variance left over the workspace sample.

Larger is better for all three.
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from models._types import Array

CHUNK = 128
"""Candidates scored at once by the worst-pose score: its temporary is CHUNK × poses × rows × 3 numbers."""
RIDGE = 1e-9
"""Added (relative to the largest eigenvalue) where the records do not yet determine every parameter."""


class AdaptiveCriterion(StrEnum):
    """What each next pose is chosen to improve most."""

    D = "D"
    """log det of the information: every parameter's uncertainty at once."""
    I = "I"  # noqa: E741  (the name of the criterion in the literature)
    """The predicted RMS TCP position error over the workspace (what `rms_tcp_mm` targets)."""
    WORST = "worst"
    """The predicted TCP position error at the worst workspace pose (what `max_tcp_mm` targets)."""


ADAPTIVE_SUMMARIES: dict[AdaptiveCriterion, str] = {
    AdaptiveCriterion.D: "every parameter's uncertainty at once (log det of the information)",
    AdaptiveCriterion.I: "the predicted RMS TCP position error over the workspace (what rms_tcp_mm targets)",
    AdaptiveCriterion.WORST: "the predicted TCP position error at the worst workspace pose (what max_tcp_mm targets)",
}
"""What each criterion makes small, as `GET /v1/adaptive-criteria` lists it (its clients keep no copy)."""


def safe_inverse(m: Array) -> Array:
    """M⁻¹, with a small ridge where M is singular (before the records determine every parameter)."""
    scale = max(float(np.max(np.abs(np.diag(m)))), 1.0)
    ridge = np.eye(m.shape[0]) * RIDGE * scale
    return np.asarray(np.linalg.inv(m + ridge), dtype=float)


def scores(criterion: AdaptiveCriterion, m: Array, blocks: Array, *, task: Array, task_rows: Array | None) -> Array:
    """(M,) each candidate's improvement of the criterion when measured next (larger is better)."""
    inv = safe_inverse(m)
    b = np.einsum("nrp,pq->nrq", blocks, inv)
    s = np.eye(blocks.shape[1])[None] + np.einsum("nrq,nsq->nrs", b, blocks)
    if criterion is AdaptiveCriterion.D:
        return np.asarray(np.linalg.slogdet(s)[1], dtype=float)
    if criterion is AdaptiveCriterion.I:
        blb = np.einsum("nrp,pq,nsq->nrs", b, task, b)
        return np.asarray(np.einsum("nrs,nsr->n", np.linalg.inv(s), blb), dtype=float)
    assert task_rows is not None
    return -worst_after(inv, b, s, task_rows)


def worst_after(inv: Array, b: Array, s: Array, task_rows: Array) -> Array:
    """(M,) the largest predicted TCP variance over the workspace sample after measuring each candidate (mm²)."""
    variance = np.einsum("kai,ij,kaj->k", task_rows, inv, task_rows)
    s_inv = np.linalg.inv(s)
    out = np.empty(b.shape[0])
    for lo in range(0, b.shape[0], CHUNK):
        c = np.einsum("nrq,kaq->nkra", b[lo : lo + CHUNK], task_rows)
        fall = np.einsum("nkra,nrs,nksa->nk", c, s_inv[lo : lo + CHUNK], c)
        out[lo : lo + CHUNK] = (variance[None, :] - fall).max(axis=1)
    return out
