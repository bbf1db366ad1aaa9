"""Structural identifiability per structure against the closed form of Everett, Hsu and Roth.

For a serial structure with a free base and tool, a complete and minimal model has 4R + 2P + 6 identifiable
parameters with full-pose measurements and 4R + 2P + 3 with positions only (R revolute, P prismatic joints).
The MDH structures below carry Hayati's beta on their parallel-axis links and a probe off the last axis.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from models import RobotDescription, iwr
from models.examples import hexapod_alone, iiwa_like, track_arm, ur5_like
from models.identifiability import structural_identifiability
from models.measurement import MeasurementKind
from models.serial_chain import JointType


def _erh(desc: RobotDescription, kind: MeasurementKind) -> int:
    r = sum(link.joint is JointType.REVOLUTE for link in desc.links)
    p = sum(link.joint is JointType.PRISMATIC for link in desc.links)
    return 4 * r + 2 * p + (6 if kind is MeasurementKind.POSE else 3)


def _count(desc: RobotDescription, kind: MeasurementKind) -> int:
    return len(structural_identifiability(desc, tuple(range(desc.n_params)), kind).identifiable)


@pytest.mark.parametrize("kind", [MeasurementKind.POSE, MeasurementKind.POSITION])
@pytest.mark.parametrize("make", [iiwa_like, track_arm, lambda: ur5_like("mdh")], ids=["7R", "track", "6R-mdh"])
def test_serial_counts_match_everett_hsu_roth(make: Callable[[], RobotDescription], kind: MeasurementKind) -> None:
    desc = make()
    assert _count(desc, kind) == _erh(desc, kind)


def test_the_7r_arm_and_the_iwr_counts() -> None:
    assert (_count(iiwa_like(), MeasurementKind.POSE), _count(iiwa_like(), MeasurementKind.POSITION)) == (34, 31)
    assert (_count(iwr(), MeasurementKind.POSE), _count(iwr(), MeasurementKind.POSITION)) == (54, 51)


def test_standard_dh_loses_one_per_parallel_pair() -> None:
    # robots.md gives beta to mdh links only: a standard-DH arm with parallel consecutive axes (the UR5's
    # shoulder-elbow-wrist, two pairs) cannot represent a tilt of one towards the other, so two fewer.
    desc = ur5_like("dh")
    assert _count(desc, MeasurementKind.POSE) == _erh(desc, MeasurementKind.POSE) - 2


def test_a_hexapod_alone() -> None:
    # 42 joint coordinates and offsets plus base and tool (12), less the 6 + 6 rigid motions of the base and
    # platform joint sets that base and tool absorb.
    desc = hexapod_alone()
    assert _count(desc, MeasurementKind.POSE) == 42
    assert _count(desc, MeasurementKind.POSITION) == 39
