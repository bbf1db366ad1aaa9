"""What a fit says about itself: covariance, variance factor, outliers, predicted accuracy.

All from the standardised Jacobian `J` (residuals in σ, unknowns in
tolerances) at the solution. With m equations and n unknowns the a-posteriori
variance factor is `s0² = Σr² / (m − n)`; it should be near 1 when the stated
noise is right, and the a-posteriori covariance is `s0² · (JᵀJ)⁻¹`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.special

from models._types import Array

CORRELATED_PAIRS = 10
NOISE_CONSISTENCY_LEVEL = 0.99
"""Two-sided confidence level of the χ² test of the variance factor."""


@dataclass(frozen=True)
class Covariance:
    z: Array
    """(n, n) a-posteriori covariance of the unknowns in tolerance units."""
    variance_factor: float
    dof: int
    noise_consistent: bool
    """Whether Σr² lies inside the central χ²(dof) interval at `NOISE_CONSISTENCY_LEVEL`."""
    chi2_interval: tuple[float, float]
    """That interval, expressed as bounds on the variance factor."""


@functools.lru_cache(maxsize=256)
def _chi2_interval(tail: float, dof: int) -> tuple[float, float]:
    """The variance factor's χ² interval; the inverse gamma costs ~0.1 ms a call and a robot repeats its dof."""
    return chi2_quantile(tail, dof) / dof, chi2_quantile(1 - tail, dof) / dof


def variance_factor_interval(dof: int) -> tuple[float, float]:
    """The central χ²(dof) interval at `NOISE_CONSISTENCY_LEVEL`, as bounds on the variance factor."""
    return _chi2_interval((1 - NOISE_CONSISTENCY_LEVEL) / 2, dof)


def chi2_quantile(p: float, dof: int) -> float:
    """The χ²(dof) quantile of probability p, 2 P⁻¹(dof/2, p) with P the regularised lower incomplete gamma:
    what scipy.stats.chi2.ppf computes, bit for bit, from scipy.special. Importing scipy.stats would cost every
    API, compute and job process 0.6 s of start-up for the two quantiles a calibration needs."""
    return float(2.0 * scipy.special.gammaincinv(dof / 2.0, p))


def chi2_upper_quantile(q: float, dof: int) -> float:
    """The χ²(dof) value exceeded with probability q (scipy.stats.chi2.isf, the same way)."""
    return float(2.0 * scipy.special.gammainccinv(dof / 2.0, q))


def covariance(jacobian: Array, residuals: Array, prior: Array | None = None) -> Covariance:
    """From the data's rows alone, or with a prior's rows `prior` ((k, n), σ per tolerance, linear): then the
    covariance is (JᵀJ / s0² + PᵀP)⁻¹ and the variance factor's degrees of freedom are m − tr(JᵀJ (JᵀJ + PᵀP)⁻¹),
    the data's equations less the share of the unknowns the data, not the prior, determine."""
    return covariance_of(jacobian, float(np.sum(residuals**2)), prior)


def covariance_of(jacobian: Array, ssr: float, prior: Array | None = None, *, projected: int = 0) -> Covariance:
    """`covariance` from the residuals' sum of squares `ssr`; `projected` more unknowns of the same fit whose
    columns were projected out of `jacobian`'s rows (a campaign's drift): they take as many degrees of freedom."""
    if prior is not None and prior.shape[0]:
        return _posterior(jacobian, ssr, prior, projected)
    m, n = jacobian.shape
    dof = m - n - projected
    s02 = ssr / dof if dof > 0 else float("nan")
    # Through the SVD rather than (JᵀJ)⁻¹: the condition number is squared in the normal equations.
    _, s, vt = np.linalg.svd(jacobian, full_matrices=False)
    inv = (vt.T / s**2) @ vt
    lo, hi = variance_factor_interval(dof) if dof > 0 else (np.nan, np.nan)
    return Covariance(
        z=s02 * inv if dof > 0 else inv,
        variance_factor=s02,
        dof=dof,
        noise_consistent=bool(dof > 0 and lo <= s02 <= hi),
        chi2_interval=(float(lo), float(hi)),
    )


def _posterior(jacobian: Array, ssr: float, prior: Array, projected: int) -> Covariance:
    m, _ = jacobian.shape
    data = jacobian.T @ jacobian
    # Through the SVD of the stacked rows, as above: the prior rows make the stack full rank.
    _, s, vt = np.linalg.svd(np.vstack([jacobian, prior]), full_matrices=False)
    inv = (vt.T / s**2) @ vt
    effective = float(np.trace(data @ inv))
    dof_real = m - effective - projected
    dof = max(round(dof_real), 0)
    s02 = ssr / dof_real if dof_real > 0 else float("nan")
    lo, hi = variance_factor_interval(dof) if dof > 0 else (np.nan, np.nan)
    if dof > 0 and np.isfinite(s02) and s02 > 0:
        _, s, vt = np.linalg.svd(np.vstack([jacobian / np.sqrt(s02), prior]), full_matrices=False)
        inv = (vt.T / s**2) @ vt
    return Covariance(
        z=inv,
        variance_factor=s02,
        dof=dof,
        noise_consistent=bool(dof > 0 and lo <= s02 <= hi),
        chi2_interval=(float(lo), float(hi)),
    )


def correlated_pairs(
    cov: Array, names: tuple[str, ...], count: int = CORRELATED_PAIRS
) -> tuple[tuple[str, str, float], ...]:
    """The `count` pairs of estimated parameters with the largest |correlation|."""
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    iu = np.triu_indices(len(names), k=1)
    values = corr[iu]
    order = np.argsort(-np.abs(values))[:count]
    return tuple((names[iu[0][k]], names[iu[1][k]], float(values[k])) for k in order)


def outlier_threshold(n_poses: int, rows: int, alpha: float) -> float:
    """χ² value a clean pose's Σr² exceeds with probability alpha/N (Bonferroni over the campaign)."""
    return chi2_upper_quantile(alpha / max(n_poses, 1), rows)


@dataclass(frozen=True)
class PoseErrors:
    position_mm: Array
    """(N,) norm of the position error per pose."""
    orientation_rad: Array | None
    """(N,) rotation angle of the orientation error per pose; None for position-only data."""
    position_xyz_mm: Array | None = None
    """(N, 3) the error itself, measured minus model, in the frame the records are in (None where unknown)."""

    @staticmethod
    def from_raw(raw: Array) -> PoseErrors:
        """From unweighted residual rows (N, 3 or 6), model minus measurement: position mm, rotation vector rad."""
        orientation = np.linalg.norm(raw[:, 3:6], axis=1) if raw.shape[1] == 6 else None
        return PoseErrors(np.linalg.norm(raw[:, :3], axis=1), orientation, -raw[:, :3])


def tcp_accuracy(jacobians: Array, cov_theta: Array) -> tuple[Array, Array]:
    """Per-pose 1-σ TCP position (mm) and orientation (rad) uncertainty, √trace of each 3×3 covariance.

    `jacobians` are (M, 6, n) pose Jacobians on the estimated parameters, `cov_theta` their covariance.
    """
    prop = (jacobians @ cov_theta) @ np.swapaxes(jacobians, 1, 2)
    pos = np.sqrt(np.clip(np.trace(prop[:, :3, :3], axis1=1, axis2=2), 0, None))
    rot = np.sqrt(np.clip(np.trace(prop[:, 3:, 3:], axis1=1, axis2=2), 0, None))
    return pos, rot
