"""The acceptance decision: which fits are applied, and the reason a refused or superseded one carries."""

from __future__ import annotations

import pytest

from models.identification.acceptance import Acceptance, Check, decide

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
