"""The identifiable set chosen on the real robot (issue 45, the IRB 2400 case).

ROS-Industrial's IRB 2400 URDF ends in `tool0` on joint 6's axis. At that nominal geometry a position record
cannot see joint 6's offset and twist, so the structure's subset has 25 parameters; the tracker's reflector is
centimetres off that axis, and at the fitted geometry 27 are identifiable. A fit that kept the nominal 25 left
two directions the records see unfitted: 2-3x the held-out error of a UR5 at the same noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, forward_kinematics, sample_workspace
from models.description.structure import description_from_document
from models.formats.urdf import document_from_urdf
from models.identifiability import structural_identifiability
from models.identification import identify
from models.measurement import MeasurementKind
from models.simulation import SimulatedRobot, measure, perturbed_robot
from tests.irb2400 import IRB2400_URDF

NOISE = NoiseModel(position_mm=0.03)
REFLECTOR_OFF_AXIS_MM = (40.0, -30.0, 10.0)
"""Where the reflector really is, from tool0 (the description says: at tool0)."""


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=1))))


@pytest.mark.slow  # ~2 s: three campaigns
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_subset_is_chosen_again_at_the_fitted_geometry(seed: int) -> None:
    desc = description_from_document(document_from_urdf(IRB2400_URDF, "base_link", "tool0"), name="irb2400")
    groups = desc.parameters.indices(("base", "links", "tool"))
    assert structural_identifiability(desc, groups, MeasurementKind.POSITION).rank == 25
    sim = perturbed_robot(desc, seed=seed)
    truth = sim.truth.copy()
    tool = desc.slices["tool"].start
    truth[tool : tool + 3] += np.asarray(REFLECTOR_OFF_AXIS_MM)
    sim = SimulatedRobot(desc, sim.nominal, truth)
    campaign = measure(sim, sample_workspace(desc, 40, seed=100 + seed), NOISE, seed=300 + seed, position_only=True)
    result = identify(desc, campaign, noise=NOISE)
    assert result.succeeded, result.reason
    assert len(result.estimated) == 27 and result.rank == 27
    assert any("at the fitted geometry 27 parameters are identifiable" in n for n in result.notes)
    fresh = sample_workspace(desc, 300, seed=200 + seed)
    error = _rms(
        forward_kinematics(desc, fresh, result.parameters).positions, forward_kinematics(desc, fresh, truth).positions
    )
    # Measured 0.023-0.032 mm (seeds 0-2; a UR5-like arm at the same noise: 0.022-0.028); the nominal subset
    # of 25 gave 0.040-0.064 mm.
    assert error < 0.04
    assert result.variance_factor < 1.4  # the 25-parameter fit left a misfit: 1.3-1.7
