"""Structural identifiability per structure against the closed form of Everett, Hsu and Roth.

For a serial structure with a free base and tool, a complete and minimal model has 4R + 2P + 6 identifiable
parameters with full-pose measurements and 4R + 2P + 3 with positions only (R revolute, P prismatic joints).
The MDH structures below carry Hayati's beta on their parallel-axis links and a probe off the last axis.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from models import RobotDescription, iwr
from models.description.examples import hexapod_alone, iiwa_like, track_arm, ur5_like, ur5_like_document
from models.description.serial_chain import JointType
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.identifiability import structural_identifiability
from models.measurement import MeasurementKind


def _erh(desc: RobotDescription, kind: MeasurementKind) -> int:
    r = sum(link.joint is JointType.REVOLUTE for link in desc.links)
    p = sum(link.joint is JointType.PRISMATIC for link in desc.links)
    return 4 * r + 2 * p + (6 if kind is MeasurementKind.POSE else 3)


def _count(desc: RobotDescription, kind: MeasurementKind) -> int:
    return len(structural_identifiability(desc, tuple(range(desc.n_params)), kind).identifiable)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("kind", [MeasurementKind.POSE, MeasurementKind.POSITION])
@pytest.mark.parametrize("make", [iiwa_like, track_arm, lambda: ur5_like("mdh")], ids=["7R", "track", "6R-mdh"])
def test_serial_counts_match_everett_hsu_roth(make: Callable[[], RobotDescription], kind: MeasurementKind) -> None:
    desc = make()
    assert _count(desc, kind) == _erh(desc, kind)


def test_the_7r_arm_and_the_iwr_counts() -> None:
    assert (_count(iiwa_like(), MeasurementKind.POSE), _count(iiwa_like(), MeasurementKind.POSITION)) == (34, 31)
    assert (_count(iwr(), MeasurementKind.POSE), _count(iwr(), MeasurementKind.POSITION)) == (54, 51)


def test_standard_dh_loses_one_per_parallel_pair() -> None:
    # Without beta (robots.md gives it to mdh links by default) a standard-DH arm with parallel consecutive
    # axes (the UR5's shoulder-elbow-wrist, two pairs) cannot represent a tilt of one towards the other.
    desc = ur5_like("dh")
    assert _count(desc, MeasurementKind.POSE) == _erh(desc, MeasurementKind.POSE) - 2
    assert _count(desc, MeasurementKind.POSITION) == _erh(desc, MeasurementKind.POSITION) - 2


def _dh_with_beta(links: tuple[int, ...]) -> RobotDescription:
    document = ur5_like_document("dh")
    for k in links:
        document["stages"][0]["links"][k]["beta"] = 0.0
    return description_from_document(document, name="ur5-hayati")


def test_the_dh_beta_example_is_the_arm_with_both_betas() -> None:
    assert ur5_like("dh-beta").structure == _dh_with_beta((1, 2)).structure


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
@pytest.mark.parametrize("kind", [MeasurementKind.POSE, MeasurementKind.POSITION])
def test_standard_dh_with_hayatis_beta_on_its_parallel_links_has_the_closed_form_count(kind: MeasurementKind) -> None:
    # The addition to robots.md: beta on the dh links whose alpha is 0 (link 2: axes 2 ∥ 3, link 3: axes 3 ∥ 4)
    # gives back the two lost parameters: 4·6 + 6 = 30 with full poses, 4·6 + 3 = 27 with positions.
    desc = _dh_with_beta((1, 2))
    assert [spec.name for spec in desc.parameters.specs if spec.name.endswith(".beta")] == ["link2.beta", "link3.beta"]
    assert desc.n_params == 6 + 6 * 4 + 2 + 6
    assert _count(desc, kind) == _erh(desc, kind) == (30 if kind is MeasurementKind.POSE else 27)
    # One pair with beta, one without: one parameter short.
    assert _count(_dh_with_beta((1,)), kind) == _erh(desc, kind) - 1


def test_beta_on_a_dh_link_whose_axes_are_not_parallel_is_refused() -> None:
    document = ur5_like_document("dh")
    document["stages"][0]["links"][0]["beta"] = 0.0  # alpha 90°
    with pytest.raises(InvalidInput) as refused:
        description_from_document(document)
    assert refused.value.field == "stages[0].links[0].beta"


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_a_hexapod_alone() -> None:
    # 42 joint coordinates and offsets plus base and tool (12), less the 6 + 6 rigid motions of the base and
    # platform joint sets that base and tool absorb.
    desc = hexapod_alone()
    assert _count(desc, MeasurementKind.POSE) == 42
    assert _count(desc, MeasurementKind.POSITION) == 39
