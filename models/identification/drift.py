"""Drift-aware identification: an instrument frame that creeps during a campaign, fitted and removed.

A laser tracker's frame drifts while a campaign runs (its stand warms, the floor settles): every record's
position is off by `d(s)`, a smooth function of the record's time (or temperature), the same for every pose.
A reference pose measured again and again through the campaign sees only `d`; the other records see the
robot and `d` together. The drift is modelled per axis as a polynomial in the driver `s` without its constant
(which the instrument frame, the base, absorbs):

    d(s) = Σ_k c_k u(s)^k,  k = 1 … degree,  u = (s − centre) / half-range ∈ [−1, 1]

and estimated jointly with the robot's parameters by variable projection: at a fit's solution the drift's
coefficients are the least-squares solution of the residuals with the parameters' Jacobian projected out
(`Tᵀ P⊥ T c = Tᵀ P⊥ r`, every row in σ), which is the joint least-squares problem's own step, and whose
inverse normal matrix is the drift's marginal covariance. The records are corrected by `d` and fitted again
until the step is a negligible fraction of its σ: two fits, since the drift enters the residuals linearly (the
second step is ~1e-4 σ). The drift is a translation of the instrument's frame; orientations are left as measured.

The robot's own thermal terms (`ModelTerms.thermal`) stay in the fit where the description has them, so a
temperature-driven instrument drift and the robot's expansion are told apart by the geometry (κ lengthens
the legs, the drift moves every point alike).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.campaign import Campaign
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput
from models.identifiability import scaled_jacobian
from models.identification.accuracy import predicted_accuracy
from models.identification.options import IdentificationOptions
from models.identification.pipeline import identify
from models.identification.result import IdentificationResult
from models.identification.statistics import correlated_pairs, covariance_of
from models.kinematics import forward_kinematics
from models.noise import NoiseModel

MAX_DEGREE = 3
"""A campaign's drift is slow: a cubic already follows a warm-up; more would follow the robot's errors."""
MAX_ROUNDS = 4
STEP_TOLERANCE = 0.01
"""The fit stops when no coefficient moved by more than this fraction of its σ."""
MAX_CONDITION = 1e10
"""Of the drift's projected normal matrix: beyond, the parameters explain what the drift would (no estimate)."""
PRISMATIC_TOLERANCE_MM = 0.005
REVOLUTE_TOLERANCE_RAD = 1e-4
"""Joints this close read as the same pose (a controller's read-back of one commanded pose)."""


Indices = NDArray[np.intp]


class DriftDriver(StrEnum):
    TIME = "time"
    """The records' time stamps (or their order, when they carry none)."""
    TEMPERATURE = "temperature"
    """The records' temperature_c (the instrument's frame moving with the hall's temperature)."""


@dataclass(frozen=True)
class DriftOptions:
    driver: DriftDriver = DriftDriver.TIME
    degree: int = 1


@dataclass(frozen=True)
class Timeline:
    """When each record of a campaign was measured, and which records are the reference pose's."""

    times_s: Array
    """(N,) seconds from any origin; the record order (0, 1, 2 …) when the records carry no time."""
    reference: Indices
    """Indices of the records that measured the reference pose, in campaign order."""
    timed: bool = True
    """False: `times_s` is the record order, not a time."""


def same_joints(desc: RobotDescription, joints: Array) -> Array:
    """(N, N) True where two records' joints read as one pose (`PRISMATIC_…`, `REVOLUTE_TOLERANCE_…`)."""
    tolerance = np.full(joints.shape[1], PRISMATIC_TOLERANCE_MM)
    tolerance[list(desc.revolute_joints)] = REVOLUTE_TOLERANCE_RAD
    return np.asarray(np.all(np.abs(joints[:, None, :] - joints[None, :, :]) <= tolerance, axis=2))


def find_reference(desc: RobotDescription, joints: Array) -> Indices:
    """The records of the pose measured most often (ties: the one measured first); InvalidInput when no
    pose is measured at least twice."""
    equal = same_joints(desc, joints)
    counts = equal.sum(axis=1)
    first = int(np.argmax(counts))  # argmax takes the first of equals: the earliest of the most repeated
    if counts[first] < 2:
        raise InvalidInput(
            "drift: no pose of the campaign is measured twice, so there is no reference pose to see the "
            "instrument drift on: measure one pose again every few records (and mark those records `reference`)",
            field="reference",
            reason="not_repeated",
        )
    return np.flatnonzero(equal[first]).astype(np.intp)


def check_reference(desc: RobotDescription, joints: Array, reference: Indices, degree: int) -> None:
    """The named reference records are one pose measured often enough to fit a drift of `degree`."""
    needed = degree + 2  # one more than the drift's unknowns per axis beside the pose itself, to test it
    if reference.size < needed:
        raise InvalidInput(
            f"drift: the reference pose is measured {reference.size} time(s); a drift of degree {degree} needs "
            f"it at least {needed} times, spread over the campaign (measure it every few records)",
            field="reference",
            reason="not_repeated",
            min=float(needed),
            value=float(reference.size),
        )
    equal = same_joints(desc, joints[reference])
    odd = np.flatnonzero(~equal[0])
    if odd.size:
        k = int(reference[odd[0]])
        worst = float(np.max(np.abs(joints[k] - joints[reference[0]])))
        raise InvalidInput(
            f"drift: records {int(reference[0])} and {k} are both marked reference but are not the same pose "
            f"(their joints differ by up to {worst:.6g} in internal units): the reference must be one pose "
            "measured again and again",
            field="reference",
            reason="not_one_pose",
            value=float(k),
        )


@dataclass(frozen=True)
class DriftEstimate:
    """The fitted drift `d(s)` and what it did to the reference pose (internal units: mm, s or °C)."""

    driver: DriftDriver
    degree: int
    coefficients_mm: Array
    """(3, degree): per axis x, y, z, the coefficient of u^k, k = 1 … degree, mm."""
    covariance_mm2: Array
    """(3·degree, 3·degree), the coefficients' marginal covariance (axis-major), mm²."""
    centre: float
    half_range: float
    span: tuple[float, float]
    """The driver's least and greatest value over the campaign (s or °C)."""
    reference: Indices
    reference_scatter_before_mm: float
    """RMS distance of the reference pose's measured positions from their mean, as measured."""
    reference_scatter_after_mm: float
    """The same after removing the drift."""
    rounds: int
    timed: bool = True

    def u(self, s: Array) -> Array:
        return (np.asarray(s, dtype=float) - self.centre) / self.half_range

    def basis(self, s: Array) -> Array:
        """(N, degree) u^1 … u^degree."""
        return _powers(self.u(s), self.degree)

    def at(self, s: Array) -> Array:
        """(N, 3) the drift at driver values `s`, mm (zero at the span's centre)."""
        return self.basis(s) @ self.coefficients_mm.T

    @property
    def total_mm(self) -> Array:
        """(3,) the drift from the span's start to its end, per axis, mm."""
        start, end = self.at(np.array(self.span))
        return np.asarray(end - start)

    @property
    def total_sigma_mm(self) -> Array:
        """(3,) σ of `total_mm`."""
        ends = self.basis(np.array(self.span))
        g = ends[1] - ends[0]  # d(end) − d(start) per axis is gᵀ c_axis
        sigmas = []
        for a in range(3):
            axis = slice(a * self.degree, (a + 1) * self.degree)
            block = self.covariance_mm2[axis, axis]
            sigmas.append(float(np.sqrt(max(g @ block @ g, 0.0))))
        return np.array(sigmas)

    @property
    def extent(self) -> float:
        """The span's length (s or K)."""
        return float(self.span[1] - self.span[0])


@dataclass(frozen=True)
class DriftResult:
    result: IdentificationResult
    """The identification of the records with the drift removed."""
    drift: DriftEstimate


def identify_with_drift(
    desc: RobotDescription,
    campaign: Campaign,
    timeline: Timeline,
    *,
    drift: DriftOptions | None = None,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    options: IdentificationOptions | None = None,
    runtime: Runtime | None = None,
) -> DriftResult:
    """Identify `desc` from `campaign` with the instrument's drift over `timeline` fitted and removed."""
    drift = drift or DriftOptions()
    noise = noise or NoiseModel()
    rt = runtime_for(desc, runtime)
    driver = _checked_driver(campaign, timeline, drift)
    check_reference(desc, campaign.joints, timeline.reference, drift.degree)
    low, high = float(np.min(driver)), float(np.max(driver))
    centre, half = 0.5 * (low + high), 0.5 * (high - low)
    basis = _powers((driver - centre) / half, drift.degree)  # (N, degree), as DriftEstimate.basis

    def fit(c: Array) -> tuple[Campaign, IdentificationResult]:
        corrected = _corrected(campaign, basis @ c.T)
        return corrected, identify(desc, corrected, noise=noise, nominal=nominal, options=options, runtime=rt)

    drift_fit = _DriftFit(desc, basis, noise, rt)
    result, coefficients, cov, rounds = _rounds(fit, drift_fit.step, drift.degree)
    if result.succeeded and result.dof > 0 and np.isfinite(result.variance_factor):
        corrected = _corrected(campaign, basis @ coefficients.T)
        result, ratio = drift_fit.with_unknowns(corrected, result, options or IdentificationOptions())
        cov = cov * ratio
    ref = timeline.reference
    estimate = DriftEstimate(
        driver=drift.driver,
        degree=drift.degree,
        coefficients_mm=coefficients,
        covariance_mm2=cov,
        centre=centre,
        half_range=half,
        span=(low, high),
        reference=ref,
        reference_scatter_before_mm=_scatter(campaign.positions[ref]),
        reference_scatter_after_mm=_scatter(campaign.positions[ref] - (basis @ coefficients.T)[ref]),
        rounds=rounds,
        timed=timeline.timed,
    )
    return DriftResult(result, estimate)


def _checked_driver(campaign: Campaign, timeline: Timeline, drift: DriftOptions) -> Array:
    """The driver's value per record, once the options and the records can determine a drift (InvalidInput)."""
    if not 1 <= drift.degree <= MAX_DEGREE:
        raise InvalidInput(
            f"drift: degree must be 1 to {MAX_DEGREE}, got {drift.degree}",
            field="degree",
            min=1.0,
            max=float(MAX_DEGREE),
            value=float(drift.degree),
        )
    driver = _driver(campaign, timeline, drift.driver)
    low, high = float(np.min(driver)), float(np.max(driver))
    if not high > low:
        raise InvalidInput(
            f"drift: every record has the same {drift.driver.value}, so nothing can change over the campaign",
            field=drift.driver.value,
            reason="constant",
        )
    distinct = int(np.unique(driver).size)
    if distinct <= drift.degree:
        raise InvalidInput(
            f"drift: a drift of degree {drift.degree} needs the records at {drift.degree + 1} or more different "
            f"{drift.driver.value} values; they have {distinct} (lower the degree, or give each record its own time)",
            field="degree",
            reason="too_few_values",
            value=float(drift.degree),
        )
    return driver


def _rounds(
    fit: Callable[[Array], tuple[Campaign, IdentificationResult]],
    step_of: Callable[[Campaign, IdentificationResult], tuple[Array, Array]],
    degree: int,
) -> tuple[IdentificationResult, Array, Array, int]:
    """Fit with the drift so far removed, step the drift from that fit's residuals, until the step is negligible:
    (the last fit, the drift's coefficients, their covariance, the number of fits)."""
    coefficients = np.zeros((3, degree))
    cov = np.full((3 * degree, 3 * degree), np.nan)
    for rounds in range(1, MAX_ROUNDS + 1):
        corrected, result = fit(coefficients)
        if not result.succeeded:
            return result, coefficients, np.full_like(cov, np.nan), rounds
        step, cov = step_of(corrected, result)
        coefficients = coefficients + step
        if float(np.max(np.abs(step).ravel() / np.sqrt(np.clip(np.diag(cov), 1e-30, None)))) <= STEP_TOLERANCE:
            return result, coefficients, cov, rounds
    # The last step still moved the drift: fit once more with it, so the parameters match the drift.
    return fit(coefficients)[1], coefficients, cov, MAX_ROUNDS + 1


def _driver(campaign: Campaign, timeline: Timeline, driver: DriftDriver) -> Array:
    if driver is DriftDriver.TEMPERATURE:
        temperature = None if campaign.conditions is None else campaign.conditions.temperature_c
        if temperature is None:
            raise InvalidInput(
                "drift: the temperature driver needs every record's temperature_c",
                field="temperature_c",
                reason="missing",
            )
        return np.asarray(temperature, dtype=float)
    times = np.asarray(timeline.times_s, dtype=float)
    if times.shape != (campaign.size,) or not np.all(np.isfinite(times)):
        raise InvalidInput(
            f"drift: expected {campaign.size} finite record times, got shape {times.shape}",
            field="time",
            reason="shape",
        )
    return times


def _powers(u: Array, degree: int) -> Array:
    """(N, degree) u^1 … u^degree: the drift's basis, without the constant the instrument frame absorbs."""
    return np.stack([u**k for k in range(1, degree + 1)], axis=1)


def _corrected(campaign: Campaign, drift_mm: Array) -> Campaign:
    return replace(campaign, positions=campaign.positions - drift_mm)


def _scatter(points: Array) -> float:
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


@dataclass(frozen=True)
class _DriftFit:
    """What each step of the drift's fit works with: the robot, the drift's basis over the campaign's records
    (N, degree: `_powers`), the noise model and the runtime."""

    desc: RobotDescription
    basis: Array
    noise: NoiseModel
    rt: Runtime

    def weighted_system(self, campaign: Campaign, result: IdentificationResult) -> tuple[Array, Array, Array]:
        """At `result`'s solution, over the records its fit kept, every row in σ: the estimated parameters'
        Jacobian J (columns in tolerance units, as the fit's), the drift's T (coefficients in mm, position rows
        only) and the position residuals r (measured − model; zero on orientation rows)."""
        # Only the records the fit kept (an excluded blunder would pull the drift as it would the parameters).
        excluded = {o.pose for o in result.outliers if o.excluded}
        keep = np.array([i for i in range(campaign.size) if i not in excluded])
        sub = campaign.subset(keep)
        fk = forward_kinematics(
            self.desc,
            sub.joints,
            result.parameters,
            jacobian=True,
            runtime=self.rt,
            conditions=sub.conditions,
            check_ranges=False,
        )
        rows = 3 if sub.position_only else 6
        jac = scaled_jacobian(fk.jacobians, self.desc.parameters, self.noise, kind=sub.kind)[:, list(result.estimated)]
        jac = jac.reshape(sub.size, rows, -1)
        # Per-record σ where the campaign gives one (the scaled Jacobian divides by the self.noise model's).
        sigma = np.full(sub.size, self.noise.position_mm) if sub.sigma_mm is None else sub.sigma_mm
        jac[:, :3, :] *= (self.noise.position_mm / sigma)[:, None, None]
        # measured − model, so the drift (added to the model) is what the residual shows
        after = result.residuals_after.per_pose_xyz_mm
        residual = sub.positions - fk.positions if after is None else after[keep]
        degree = self.basis.shape[1]
        design = np.zeros((sub.size, rows, 3 * degree))
        for a in range(3):
            design[:, a, a * degree : (a + 1) * degree] = self.basis[keep] / sigma[:, None]
        target = np.zeros((sub.size, rows))
        target[:, :3] = residual / sigma[:, None]
        return jac.reshape(sub.size * rows, -1), design.reshape(sub.size * rows, -1), target.reshape(-1)

    def step(self, campaign: Campaign, result: IdentificationResult) -> tuple[Array, Array]:
        """The drift coefficients' least-squares step from `result`'s residuals with the estimated parameters'
        Jacobian projected out, and their marginal covariance (scaled by the fit's variance factor), mm / mm²."""
        j, t, r = self.weighted_system(campaign, result)
        degree = self.basis.shape[1]
        q, _ = np.linalg.qr(j)
        t_perp = t - q @ (q.T @ t)
        normal = t_perp.T @ t_perp
        if np.linalg.cond(normal) > MAX_CONDITION:
            raise InvalidInput(
                "drift: the drift cannot be told apart from the robot's parameters in this campaign (what it does to "
                "the records, the instrument frame or a term does as well): measure the reference pose at more times, "
                "or lower the degree",
                field="drift",
                reason="not_identifiable",
            )
        # At the fit's solution the whole residual (orientation rows too) is orthogonal to the parameters' columns,
        # so Tᵀ P⊥ r = Tᵀ r, and T has no orientation rows: the position residuals alone give the step exactly
        # (the orientation residuals, which this Jacobian's rows express in another frame, are never needed).
        step = np.linalg.solve(normal, t.T @ r)
        factor = result.variance_factor if np.isfinite(result.variance_factor) else 1.0
        cov = np.asarray(factor * np.linalg.inv(normal), dtype=np.float64)
        return np.asarray(step.reshape(3, degree), dtype=float), cov

    def with_unknowns(
        self, campaign: Campaign, result: IdentificationResult, options: IdentificationOptions
    ) -> tuple[IdentificationResult, float]:
        """`result` (the last fit, of the records with the drift removed) with its statistics those of the joint
        problem, robot and drift together: the parameters' covariance the marginal (Jᵀ P⊥ J)⁻¹, P⊥ projecting out the
        drift's columns (the drift's uncertainty widens the parameters'), and the variance factor over the data's
        rows less both sets of unknowns. Then the σ, correlations and predicted accuracy that follow. Also the ratio
        of the joint variance factor to the fit's, which the drift's own covariance takes."""
        j, t, _ = self.weighted_system(campaign, result)
        q, _ = np.linalg.qr(t)
        j_perp = j - q @ (q.T @ j)
        free = np.array(result.estimated)
        table = self.desc.parameters
        prior = None if options.prior is None else options.prior.rows(result.parameters, free, table.scales[free])
        # The fit's sum of squares (its rows at its solution; drift removed, so the joint problem's too). With a prior
        # its dof is rounded: the sum is then off by under half a row's share.
        ssr = result.variance_factor * result.dof
        joint = covariance_of(j_perp, ssr, None if prior is None else prior.jacobian, projected=t.shape[1])
        scales = table.scales[free]
        cov_theta = joint.z * np.outer(scales, scales)
        std = np.full(len(table), np.nan)
        std[free] = np.sqrt(np.diag(cov_theta))
        accuracy = predicted_accuracy(
            self.desc, result.parameters, free, cov_theta, options.workspace_samples, runtime=self.rt
        )
        widened = replace(
            result,
            std_errors=std,
            covariance=cov_theta,
            correlated_pairs=correlated_pairs(cov_theta, tuple(table.names[i] for i in free)),
            variance_factor=joint.variance_factor,
            dof=joint.dof,
            noise_consistent=joint.noise_consistent,
            variance_interval=joint.chi2_interval,
            predicted_accuracy=accuracy,
        )
        ratio = joint.variance_factor / result.variance_factor if result.variance_factor > 0 else 1.0
        return widened, ratio
