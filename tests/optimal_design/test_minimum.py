"""Pose design and identification agree on the fewest poses: a design of that many is a campaign the
identification accepts, one fewer is refused by both with the same number."""

from __future__ import annotations

import pytest

from models import iwr, sample_workspace
from models.errors import TooFewMeasurements
from models.identifiability import minimum_poses
from models.identification import identify
from models.measurement import MeasurementKind
from models.simulation import measure, perturbed_robot
from optimal_design import design_poses

DESC = iwr()


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("measurement", ["pose", "position"])
def test_design_and_identification_share_the_minimum(measurement: str) -> None:
    kind = MeasurementKind(measurement)
    _, needed = minimum_poses(DESC, DESC.parameters.indices(("base", "carriage", "hexapod", "tool")), kind)
    candidates = sample_workspace(DESC, 120, seed=4)
    with pytest.raises(TooFewMeasurements) as refused:
        design_poses(DESC, needed - 1, "D", measurement, candidates=candidates)
    assert refused.value.needed == needed
    design = design_poses(DESC, needed, "D", measurement, candidates=candidates)
    sim = perturbed_robot(DESC, seed=5)
    campaign = measure(sim, design.joints, seed=6, position_only=kind is MeasurementKind.POSITION)
    identify(DESC, campaign)  # accepted: no TooFewMeasurements
    with pytest.raises(TooFewMeasurements) as too_few:
        identify(DESC, campaign.subset(range(needed - 1)))
    assert too_few.value.needed == needed
