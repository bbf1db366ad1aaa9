"""The acceptance decision: which fits are applied, and the reason a refused or superseded one carries."""

from __future__ import annotations

import math

import pytest

from models.identification.acceptance import ACCURACY_TOLERANCE, Acceptance, Check, accuracy_tolerance, decide

PASSED = (Check("fit", True, "converged"), Check("noise", True, "variance factor 1.02"))
FAILED = (Check("fit", True, "converged"), Check("noise", False, "too noisy"), Check("accuracy", False, "worse"))


@pytest.mark.parametrize(
    ("checks", "succeeded", "requested", "force", "expected"),
    [
        (PASSED, True, True, False, Acceptance(apply=True)),
        (FAILED, True, True, False, Acceptance(apply=False, reason="too noisy; worse")),
        (FAILED, True, True, True, Acceptance(apply=True, forced=True)),
        (PASSED, True, True, True, Acceptance(apply=True)),  # nothing to force
        # Not asked, or nothing to apply: no verdict at all.
        (FAILED, True, False, True, Acceptance(apply=False)),
        ((Check("fit", False, "diverged"),), False, True, True, Acceptance(apply=False)),
    ],
)
def test_decide(checks: tuple[Check, ...], succeeded: bool, requested: bool, force: bool, expected: Acceptance) -> None:
    assert decide(checks, succeeded=succeeded, requested=requested, force=force) == expected


def test_a_superseded_fit_is_not_applied_and_keeps_what_was_forced() -> None:
    lost = decide(FAILED, succeeded=True, requested=True, force=True).superseded("conflict: version 3")
    assert lost == Acceptance(apply=False, reason="conflict: version 3", forced=True)


def test_a_prediction_within_its_own_uncertainty_is_as_good_as_the_start() -> None:
    """The predicted RMS scales with the a-posteriori variance factor (χ²/dof): two predictions from campaigns
    of 306 degrees of freedom each differ by a relative standard error of √(1/612 + 1/612) = 5.7 %."""
    allowed = accuracy_tolerance(306, 306)
    assert allowed == pytest.approx(1 + 2 * math.sqrt(2 / 612))
    assert allowed * 0.0212 >= 0.0223  # the re-calibration 5 % worse that was refused
    assert allowed * 0.0212 < 0.0255  # 20 % worse is worse
    assert accuracy_tolerance(306, None) == allowed  # the start's dof unknown: taken as this one's
    assert accuracy_tolerance(10**9, 10**9) == ACCURACY_TOLERANCE  # never tighter than the round-off's 2 %
