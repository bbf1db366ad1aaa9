"""ISO 9283 characteristics against hand-computed values and against the statistics of a known noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models.errors import InvalidInput, WrongShape
from models.evaluation.iso9283 import (
    abc_angles,
    distance_characteristics,
    group_cycles,
    iso_cube,
    pose_characteristics,
)
from models.transforms import rotvec_to_matrix_np


def _rz_ry_rx(a: float, b: float, c: float) -> np.ndarray:
    ca, sa, cb, sb, cc, sc = math.cos(a), math.sin(a), math.cos(b), math.sin(b), math.cos(c), math.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return np.asarray(rz @ ry @ rx)


def test_pose_accuracy_and_repeatability_by_hand() -> None:
    # Three cycles around the command (0, 0, 0): barycentre (1, 2, 2) → AP = 3 exactly.
    attained = np.array([[1.0, 2.0, 2.0], [1.0, 2.0, 5.0], [1.0, 2.0, -1.0]])
    got = pose_characteristics([0, 0, 0], attained)
    assert got.accuracy_mm == pytest.approx(3.0)
    np.testing.assert_allclose(got.accuracy_xyz_mm, [1, 2, 2])
    # l_j = 0, 3, 3: l̄ = 2, S_l = sqrt(((0-2)² + 1 + 1) / 2) = sqrt(3) → RP = 2 + 3√3.
    assert got.repeatability_mm == pytest.approx(2 + 3 * math.sqrt(3))
    assert got.cycles == 3 and got.orientation_accuracy_rad is None


def test_orientation_accuracy_and_repeatability_by_hand() -> None:
    command = _rz_ry_rx(0.1, -0.2, 3.1)
    # c readings straddle ±π: 3.1 + {0.02, 0.06, 0.1} wraps past π for the last two.
    cs = [3.12, 3.16 - 2 * math.pi, 3.20 - 2 * math.pi]
    rotations = np.stack([_rz_ry_rx(0.1 + da, -0.2, c) for da, c in zip((0.0, 0.01, 0.02), cs, strict=True)])
    got = pose_characteristics([0, 0, 0], np.array([[0.0, 0, 0], [0, 0, 1], [0, 0, 2]]), command, rotations)
    assert got.orientation_accuracy_rad is not None and got.orientation_repeatability_rad is not None
    np.testing.assert_allclose(got.orientation_accuracy_rad, [0.01, 0.0, 0.06], atol=1e-12)
    # S of {0, .01, .02} = 0.01, of {.02, .06, .10} = 0.04.
    np.testing.assert_allclose(got.orientation_repeatability_rad, [0.03, 0.0, 0.12], atol=1e-12)


def test_abc_angles_invert_the_convention() -> None:
    rng = np.random.default_rng(3)
    angles = rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(50, 3))
    got = abc_angles(np.stack([_rz_ry_rx(*a) for a in angles]))
    np.testing.assert_allclose(got, angles, atol=1e-12)


def test_distance_accuracy_by_hand() -> None:
    a = np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0]])
    b = np.array([[100.0, 0, 0], [101.0, 0, 0], [102.0, 0, 0]])
    got = distance_characteristics([0, 0, 0], [0, 100.5, 0], a, b)
    assert got.commanded_mm == pytest.approx(100.5)
    assert got.accuracy_mm == pytest.approx(101.0 - 100.5)
    assert got.repeatability_mm == pytest.approx(3.0)  # S of {100, 101, 102} = 1


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_repeatability_matches_the_noise_it_was_made_of() -> None:
    """Isotropic Gaussian noise σ per axis: l = σ·χ₃, so E[l] = 2√2/√π σ and sd(l) = √(3 − 8/π) σ."""
    sigma, cycles = 0.025, 20_000
    rng = np.random.default_rng(7)
    command = np.array([400.0, -50.0, 1200.0])
    bias = np.array([0.03, -0.04, 0.12])
    attained = command + bias + rng.normal(scale=sigma, size=(cycles, 3))
    got = pose_characteristics(command, attained)
    expected_rp = sigma * (2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi))
    assert got.repeatability_mm == pytest.approx(expected_rp, rel=0.02)
    assert got.accuracy_mm == pytest.approx(float(np.linalg.norm(bias)), abs=3 * sigma / math.sqrt(cycles) * 3)
    tilt = np.stack([rotvec_to_matrix_np(v) for v in rng.normal(scale=1e-4, size=(cycles, 3))])
    got = pose_characteristics(command, attained, np.eye(3), tilt)
    assert got.orientation_repeatability_rad is not None
    np.testing.assert_allclose(got.orientation_repeatability_rad, 3e-4, rtol=0.03)


def test_cycles_are_grouped_by_joint_command() -> None:
    q = np.array([[1.0, 2.0], [3.0, 4.0], [1.0, 2.0 + 1e-12], [3.0, 4.0], [5.0, 6.0]])
    assert [g.tolist() for g in group_cycles(q)] == [[0, 2], [1, 3], [4]]


def test_the_cube_points_of_the_standard() -> None:
    cube = iso_cube([0, 0, 1000], 400.0)
    np.testing.assert_allclose(cube.points[0], [0, 0, 1000])
    c1, c7 = cube.corners[0], cube.corners[6]
    np.testing.assert_allclose(c1, [-200, -200, 800])
    diagonal = np.linalg.norm(c7 - c1)
    assert diagonal == pytest.approx(400 * math.sqrt(3))
    # P2 at 10 % of the diagonal from C1, on the diagonal; all five points in the plane C1–C2–C7–C8.
    assert np.linalg.norm(cube.points[1] - c1) == pytest.approx(0.1 * diagonal)
    normal = np.cross(cube.corners[1] - c1, cube.corners[7] - c1)
    np.testing.assert_allclose((cube.points - c1) @ normal, 0, atol=1e-9)


def test_bad_input() -> None:
    with pytest.raises(InvalidInput, match="2 cycles"):
        pose_characteristics([0, 0, 0], [[0, 0, 0]])
    with pytest.raises(WrongShape):
        pose_characteristics([0, 0, 0], [[0, 0], [1, 1]])
    with pytest.raises(InvalidInput, match="edge"):
        iso_cube([0, 0, 0], -1.0)
