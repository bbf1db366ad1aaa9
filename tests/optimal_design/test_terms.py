"""Pose design with the model terms: their columns in the information, and conditions the design spreads."""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, forward_kinematics, iwr, sample_workspace, scaled_jacobian
from models.description.terms import ModelTerms, make_conditions
from models.errors import InvalidInput
from optimal_design import design_poses

THERMAL = iwr().with_terms(ModelTerms(thermal=True))
LEVELS = make_conditions(3, [16.0, 22.0, 28.0])


def _kappa_sigma(joints: np.ndarray, temps: np.ndarray, free: tuple[int, ...]) -> float:
    """σ of κ_legs (ppm/K) a campaign at these poses and temperatures gives, from its own scaled Jacobian."""
    fk = forward_kinematics(THERMAL, joints, jacobian=True, conditions=make_conditions(len(temps), temps))
    a = scaled_jacobian(fk.jacobians, THERMAL.parameters, NoiseModel())[:, list(free)]
    cov = np.linalg.inv(a.T @ a)
    k = free.index(THERMAL.parameters.index["thermal.legs"])
    return float(np.sqrt(cov[k, k]) * THERMAL.parameters.scales[THERMAL.parameters.index["thermal.legs"]] * 1e6)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_design_over_temperature_levels_spreads_them_and_informs_kappa() -> None:
    design = design_poses(THERMAL, 30, "D", candidate_count=300, seed=3, levels=LEVELS)
    assert {"thermal.legs", "thermal.axes"} <= set(design.identifiable)
    assert design.conditions is not None and design.conditions.temperature_c is not None
    temps = design.conditions.temperature_c
    assert temps.shape == (30,) and set(np.unique(temps)) <= {16.0, 22.0, 28.0}
    # D-optimal for κ: the extremes, both of them, carry most of the poses
    assert np.sum(temps == 16.0) >= 5 and np.sum(temps == 28.0) >= 5
    free = tuple(THERMAL.parameters.index[n] for n in design.identifiable)
    designed = _kappa_sigma(design.joints, temps, free)
    rng = np.random.default_rng(4)
    random_poses = sample_workspace(iwr(), 30, seed=5)
    randoms = [_kappa_sigma(random_poses, rng.choice([16.0, 22.0, 28.0], 30), free) for _ in range(5)]
    assert designed < min(randoms)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_without_levels_the_terms_have_no_information() -> None:
    design = design_poses(THERMAL, 30, "D", candidate_count=300, seed=3)
    assert design.conditions is None
    assert "thermal.legs" not in design.identifiable and len(design.identifiable) == 54


def test_conditions_of_given_candidates() -> None:
    cand = sample_workspace(iwr(), 120, seed=6)
    temps = np.linspace(16.0, 28.0, 120)
    design = design_poses(THERMAL, 30, "D", candidates=cand, conditions=make_conditions(120, temps))
    assert design.conditions is not None and design.conditions.temperature_c is not None
    assert np.allclose(design.conditions.temperature_c, temps[list(design.indices)])
    with pytest.raises(InvalidInput) as err:
        design_poses(THERMAL, 30, "D", candidates=cand, conditions=make_conditions(10, 20.0))
    assert err.value.field == "conditions"
