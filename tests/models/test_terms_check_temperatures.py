"""A campaign's temperatures on a robot the thermal term cannot expand (issue 45: a 6R arm's Leica file with a
Temperature column crashed the score test with an empty set of columns, a 500)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from models import iwr, sample_workspace
from models.description.examples import track_arm, ur5_like
from models.description.terms import make_conditions
from models.identification import identify
from models.identification.terms_check import thermal_axes, unused_temperature_note
from models.noise import NoiseModel
from models.simulation import measure, perturbed_robot


def test_only_legs_and_prismatic_axes_take_a_temperature() -> None:
    assert not thermal_axes(ur5_like()) and thermal_axes(iwr()) and thermal_axes(track_arm())
    conditions = make_conditions(3, [20.0, 21.5, 23.0])
    note = unused_temperature_note(ur5_like(), conditions)
    assert note is not None and "span 3 K" in note and "unused" in note
    assert unused_temperature_note(iwr(), conditions) is None
    assert unused_temperature_note(ur5_like(), make_conditions(3)) is None


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_6r_fit_that_fails_its_variance_test_with_temperatures_ends_without_a_crash() -> None:
    desc = ur5_like()
    campaign = measure(
        perturbed_robot(desc, seed=7), sample_workspace(desc, 40, seed=8), NoiseModel(0.2, math.radians(0.01)), seed=9
    )
    with_temps = replace(campaign, conditions=make_conditions(campaign.size, np.linspace(19.0, 24.0, campaign.size)))
    result = identify(desc, with_temps, noise=NoiseModel(0.01, math.radians(0.01)))  # σ stated 20× too small
    assert not result.noise_consistent  # the score test ran: the residuals are 20× the stated σ
    assert not any("temperature term may be missing" in n for n in result.notes)
