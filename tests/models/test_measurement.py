"""One vocabulary for what an instrument measures."""

from __future__ import annotations

import numpy as np

from models import MeasurementKind, RobotDescription, make_campaign, sample_workspace
from models.identifiability import measurement_rows


def test_kinds_rows_and_the_older_flag(desc: RobotDescription) -> None:
    assert MeasurementKind.of(True) is MeasurementKind.POSITION is MeasurementKind.of("position")
    assert MeasurementKind.of(False) is MeasurementKind.POSE is MeasurementKind.of(MeasurementKind.POSE)
    assert [measurement_rows(k) for k in MeasurementKind] == [6, 3]
    joints = sample_workspace(desc, 2, seed=1)
    assert make_campaign(desc, joints, np.zeros((2, 3))).kind is MeasurementKind.POSITION
    full = make_campaign(desc, joints, np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))
    assert full.kind == "pose" and not full.position_only
