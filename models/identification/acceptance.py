"""Whether a calibration may become the robot's parameters: the checks a fit must pass before it is applied.

A fit can converge and still be wrong for the robot: noise stated five times too small, poses that determine
fewer parameters than the structure has, a result that predicts worse than the version it started from. Each
check says what it found in words an engineer can act on; the service applies only a result that passes all
(or one the user forces, which it records).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from models.identification.result import IdentificationResult

RESIDUAL_TOLERANCE = 1.1
ACCURACY_TOLERANCE = 1.02
"""A prediction within 2 % of the start version's is as good: the same campaign fitted again from its own
result predicts the same accuracy to the last digits (0.0962 mm "worse than" 0.0962 mm was a refusal)."""
ACCURACY_SIGMAS = 2.0
"""How many of its own standard errors a prediction may exceed the start's by. A predicted accuracy is a
statistic: its covariance scales with the variance factor, which fluctuates as χ²/dof, so the predicted RMS has
a relative standard error of 1/√(2 dof) — 4 % for a 60-pose IWR campaign (dof 306). A re-calibration 5 % worse
(0.0223 against 0.0212 mm) is the same accuracy within that, and was refused."""


def accuracy_tolerance(dof: int, start_dof: int | None) -> float:
    """The factor by which a prediction may exceed the start's and still be as good: `ACCURACY_SIGMAS` standard
    errors of their ratio (both predictions' own, the start's dof taken as this one's when unknown), at least
    `ACCURACY_TOLERANCE`."""
    if dof <= 0:
        return ACCURACY_TOLERANCE
    other = start_dof if start_dof is not None and start_dof > 0 else dof
    spread = math.sqrt(1.0 / (2 * dof) + 1.0 / (2 * other))
    return max(ACCURACY_TOLERANCE, 1.0 + ACCURACY_SIGMAS * spread)


@dataclass(frozen=True)
class Check:
    name: str
    """"fit", "noise", "identifiable", "residuals" or "accuracy"."""
    passed: bool
    detail: str
    blocking: bool = True
    """A failed check that blocks applying. The noise check never does: a stated σ that the residuals contradict
    says nothing against the geometry (the a-posteriori covariance takes σ from the residuals); it is said, with
    the estimate, and the result is applied."""

    @classmethod
    def of(cls, name: str, passed: bool, if_passed: str, if_failed: str) -> Check:
        """The check `name`, described by whichever of the two outcomes it had."""
        return cls(name, passed, if_passed if passed else if_failed)


def acceptance_checks(
    result: IdentificationResult,
    *,
    expected_rank: int,
    start_accuracy_mm: float | None,
    sigma_mm: float,
    held_accuracy_mm: float | None = None,
    start_dof: int | None = None,
    sigma_stated: bool = True,
) -> tuple[Check, ...]:
    """The checks of `result`: `expected_rank` is the structure's identifiable count for what was estimated and
    how it was measured; `start_accuracy_mm` the start version's predicted RMS TCP accuracy (None: unknown, as for
    the nominal geometry, which no calibration backs); `sigma_mm` the stated position noise.

    `held_accuracy_mm`: for a partial re-fit that held calibrated parameters at the start version's values, their
    own predicted TCP uncertainty (RMS, 3-D). It adds to what the residuals may show — measured: a base-only re-fit
    after a 60-pose calibration gives a variance factor of 1.44 against the noise alone, 1.13 with it.

    `sigma_stated`: False when neither the request nor the records gave σ (`sigma_mm` was a default): the noise
    check then reports σ as estimated from the residuals, with its standard error, and has nothing to test.
    """
    # Long on purpose: one block a check, each with its own words: splitting them would scatter the acceptance
    # rule.
    if not result.succeeded:
        return (Check("fit", False, result.reason or "the fit failed"),)
    checks = [Check("fit", True, f"converged ({result.solver.status}, {result.solver.iterations} iterations)")]
    raw, (lo, hi) = result.variance_factor, result.variance_interval
    held = 0.0 if held_accuracy_mm is None else held_accuracy_mm**2 / 3.0  # per axis
    factor = raw * sigma_mm**2 / (sigma_mm**2 + held)
    ratio = math.sqrt(factor) if math.isfinite(factor) and factor > 0 else float("nan")
    allowed = "" if held == 0.0 else f", allowing for the held parameters' {held_accuracy_mm:.3g} mm"
    estimate = noise_estimate(sigma_mm, factor, result.dof)
    if not sigma_stated:
        checks.append(Check("noise", True, f"σ not stated: {estimate} (the standard errors use it)"))
    elif lo <= factor <= hi:
        checks.append(
            Check("noise", True, f"variance factor {factor:.3g} within [{lo:.3g}, {hi:.3g}]{allowed}; {estimate}")
        )
    else:
        side = "larger" if factor > hi else "smaller"
        advice = (
            "state the instrument's real σ, or look for a temperature or load effect"
            if side == "larger"
            else "the stated σ is pessimistic: state the real one"
        )
        checks.append(
            Check(
                "noise",
                False,
                f"the residuals look {ratio:.2g}× {side} than the stated σ (variance factor {factor:.3g} outside "
                f"[{lo:.3g}, {hi:.3g}]{allowed}); {estimate}, which the standard errors and the predicted accuracy "
                f"use: {advice}. Not a reason to hold the calibration back",
                blocking=False,
            )
        )
    checks.append(
        Check.of(
            "identifiable",
            result.rank >= expected_rank,
            f"{result.rank} parameters identified, as the structure allows",
            f"these poses identify only {result.rank} of the {expected_rank} parameters the structure allows: "
            "measure more varied poses (a pose design picks them)",
        )
    )
    before, after = result.residuals_before.rms_mm, result.residuals_after.rms_mm
    # A re-fit from a calibrated version starts where the residuals are already at the noise: allow their
    # wobble (the fit minimises weighted residuals; this compares the unweighted RMS).
    checks.append(
        Check.of(
            "residuals",
            after <= RESIDUAL_TOLERANCE * before,
            f"RMS error on these poses {before:.4g} → {after:.4g} mm",
            f"the fit leaves these poses worse than it found them ({before:.4g} → {after:.4g} mm)",
        )
    )
    predicted = result.predicted_accuracy.rms_position_mm
    if start_accuracy_mm is None:
        checks.append(Check("accuracy", True, f"predicted TCP accuracy {predicted:.4g} mm RMS (start: uncalibrated)"))
    elif predicted <= (allowed_ratio := accuracy_tolerance(result.dof, start_dof)) * start_accuracy_mm:
        checks.append(
            Check(
                "accuracy",
                True,
                f"predicted TCP accuracy {predicted:.4g} mm RMS, start {start_accuracy_mm:.4g} mm (as good within "
                f"{100 * (allowed_ratio - 1):.2g} %, the predictions' own uncertainty)",
            )
        )
    else:
        checks.append(
            Check(
                "accuracy",
                False,
                f"predicted TCP accuracy {predicted:.4g} mm RMS is worse than the start version's "
                f"{start_accuracy_mm:.4g} mm by more than the predictions' own uncertainty "
                f"({100 * (allowed_ratio - 1):.2g} %): this campaign would make the robot less accurate",
            )
        )
    return tuple(checks)


@dataclass(frozen=True)
class Acceptance:
    """What becomes of a fit: applied, or not and why. Only a fit that succeeded and was asked to be applied gets
    a verdict; any other is simply not applied (no reason: nobody asked)."""

    apply: bool
    """The result becomes the robot's parameters, if the version it started from is still current then."""
    reason: str | None = None
    """Why a fit asked to be applied is not: its failed checks, or the version that became current meanwhile."""
    forced: bool = False
    """Applied although a check failed (force_apply)."""

    def superseded(self, reason: str) -> Acceptance:
        """Not applied after all: another version became current while the fit ran. `forced` stays what it was,
        so the stored calibration still says that force_apply overrode a failed check."""
        return replace(self, apply=False, reason=reason)


def decide(checks: tuple[Check, ...], *, succeeded: bool, requested: bool, force: bool) -> Acceptance:
    """The one decision: `requested` (the request's `apply`) of a fit that `succeeded` applies when every check
    passed, or, `force` (force_apply), in spite of the failed ones. A failed fit is never applied."""
    if not (succeeded and requested):
        return Acceptance(apply=False)
    refused = failed_checks(checks)
    if refused is None:
        return Acceptance(apply=True)
    return Acceptance(apply=True, forced=True) if force else Acceptance(apply=False, reason=refused)


def noise_estimate(sigma_mm: float, factor: float, dof: int) -> str:
    """σ as the residuals estimate it (σ·√factor) with its standard error (≈ σ̂/√(2·dof), from χ²/dof's), in
    words; where the records carried their own σ, the same words are about the scale of those."""
    if not (math.isfinite(factor) and factor > 0 and dof > 0):
        return "σ cannot be estimated from these residuals (no redundancy)"
    sigma = sigma_mm * math.sqrt(factor)
    return f"σ from the residuals {sigma:.3g} ± {sigma / math.sqrt(2 * dof):.2g} mm (1 σ, {dof} degrees of freedom)"


def failed_checks(checks: tuple[Check, ...]) -> str | None:
    """One reason naming every failed check that blocks applying, or None when none did."""
    failed = [c.detail for c in checks if not c.passed and c.blocking]
    return "; ".join(failed) if failed else None
