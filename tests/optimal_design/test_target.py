"""Target mode against an exhaustive scan of K, the unreachable case, and augmentation with target mode."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from models import RobotDescription, sample_workspace
from models.errors import InvalidInput
from optimal_design import TargetUnreachable, design_for_target, design_poses, metrics
from optimal_design.information import candidate_information
from optimal_design.problem import DesignInputs, DesignOptions

N = 40


@pytest.fixture(scope="module")
def joints(desc: RobotDescription) -> np.ndarray:
    return sample_workspace(desc, N, seed=71)


def _scan(desc: RobotDescription, joints: np.ndarray, key: str, fixed: np.ndarray | None = None) -> dict[int, float]:
    """Every K: the I design's predicted error (the truth the target mode must agree with)."""
    out = {}
    # The campaign's minimum (models.identifiability.poses_for): 54 parameters, 6 rows a pose, one spare row.
    low = 10 if fixed is None else max(1, 10 - fixed.shape[0])
    for k in range(low, joints.shape[0] + 1):
        out[k] = design_poses(desc, k, "I", candidates=joints, fixed=fixed).metrics[key]
    return out


def _first(scan: dict[int, float], goal: float) -> int:
    return min(k for k, v in scan.items() if v <= goal)


@pytest.mark.slow  # a design per K of the scan: ~6 s here
def test_smallest_count_matches_an_exhaustive_scan(desc: RobotDescription, joints: np.ndarray) -> None:
    scan = _scan(desc, joints, "predicted_rms_tcp_mm")
    values = sorted(scan.values())
    # goals between the values the scan produced, from hard to easy
    for goal in (values[1] * 1.001, float(np.median(values)), values[-3] * 0.999 + values[-2] * 0.001):
        result = design_for_target(desc, rms_tcp_mm=goal, criterion="I", candidates=joints)
        assert result.count == _first(scan, goal), goal
        assert result.design is not None and result.design.metrics["predicted_rms_tcp_mm"] <= goal
        assert len(result.design.indices) == result.count
        points = {p["count"]: p for p in result.curve}
        assert result.count in points
        for k, p in points.items():
            # the curve's I errors are those of the design at that K, and the certificate is below them
            assert p["I_rms_tcp_mm"] == pytest.approx(scan[k], rel=1e-9)
            assert p["bound_rms_tcp_mm"] <= p["I_rms_tcp_mm"] * (1 + 1e-9)
            assert p["D_rms_tcp_mm"] > 0 and p["random_rms_tcp_mm"] > 0


@pytest.mark.slow  # a design per K of the scan: ~9 s here
def test_worst_pose_target_matches_a_scan(desc: RobotDescription, joints: np.ndarray) -> None:
    scan = _scan(desc, joints, "predicted_max_tcp_mm")
    goal = float(np.median(list(scan.values())))
    result = design_for_target(desc, max_tcp_mm=goal, criterion="I", candidates=joints)
    assert result.count == _first(scan, goal)
    # the worst pose is independently the max over the workspace rows of the predicted 3-D variance
    info = candidate_information(desc, joints, position_only=False)
    assert result.design is not None and info.task_rows is not None
    m = info.subset_information(np.array(result.design.indices))
    inv = np.linalg.inv(m)
    worst = max(float(np.sqrt(np.trace(r @ inv @ r.T))) for r in info.task_rows)
    assert result.design.metrics["predicted_max_tcp_mm"] == pytest.approx(worst, rel=1e-9)


def test_unreachable_target_says_what_can_be_reached(desc: RobotDescription, joints: np.ndarray) -> None:
    info = candidate_information(desc, joints, position_only=False)
    everything = metrics(info.subset_information(np.arange(N)), 6 * N, info.task)["predicted_rms_tcp_mm"]
    with pytest.raises(TargetUnreachable, match="best reachable") as err:
        design_for_target(desc, rms_tcp_mm=0.9 * everything, candidates=joints)
    assert err.value.data["reachable_mm"] == pytest.approx(everything, rel=1e-9)
    assert isinstance(err.value, InvalidInput)  # the service maps it to a 422
    # just above it, every candidate is the answer
    result = design_for_target(desc, rms_tcp_mm=everything * 1.000001, candidates=joints)
    assert result.count <= N and result.design is not None


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_augmentation_with_a_target(desc: RobotDescription, joints: np.ndarray) -> None:
    """'I measured these 12; how many more for x mm?', against a scan of K with the same fixed poses."""
    measured = sample_workspace(desc, 12, seed=72)
    scan = _scan(desc, joints[:24], "predicted_rms_tcp_mm", fixed=measured)
    goal = float(np.median(list(scan.values())))
    result = design_for_target(desc, rms_tcp_mm=goal, candidates=joints[:24], fixed=measured)
    assert result.count == _first(scan, goal)
    assert result.design is not None and result.design.fixed == 12
    assert result.fixed_mm is not None and result.fixed_mm > goal
    # a goal the measured poses already meet needs no more
    easy = design_for_target(desc, rms_tcp_mm=result.fixed_mm * 1.01, candidates=joints[:24], fixed=measured)
    assert easy.count == 0 and easy.design is None


def test_target_input(desc: RobotDescription, joints: np.ndarray) -> None:
    with pytest.raises(InvalidInput, match="exactly one"):
        design_for_target(desc, candidates=joints)
    with pytest.raises(InvalidInput, match="exactly one"):
        design_for_target(desc, rms_tcp_mm=0.1, max_tcp_mm=0.1, candidates=joints)
    with pytest.raises(InvalidInput, match="positive"):
        design_for_target(desc, rms_tcp_mm=-1.0, candidates=joints)
    with pytest.raises(InvalidInput, match="D or I"):
        design_for_target(desc, rms_tcp_mm=0.1, criterion="E", candidates=joints)


def test_the_design_keywords_are_the_problem_inputs_but_the_measurement() -> None:
    """`DesignOptions` (the keywords of both entry points) and `DesignInputs` (what the problem is built from) are
    declared apart: a field added to one and not the other would be dropped or refused."""
    assert set(DesignOptions.__annotations__) == {f.name for f in fields(DesignInputs)} - {"measurement"}
