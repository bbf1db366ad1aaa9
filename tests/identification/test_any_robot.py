"""Identification, compensation and inverse kinematics of robots of any structure, against known truths.

Per structure: a perturbed simulated robot (thesis-sized errors on every link and leg, a tool off by 0.5 mm
and 0.2°, the instrument 3 m away at a random rotation) is measured with noise and identified; the model's
error on fresh poses must stay within 1.3× the Cramér–Rao prediction computed from the truth's Jacobians.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from models import NoiseModel, RobotDescription, forward_kinematics, sample_workspace
from models.compensation import inverse_kinematics
from models.description.examples import hexapod_alone, iiwa_like, track_arm, ur5_like
from models.description.structure import description_from_document
from models.error_analysis import ErrorMagnitudes, error_analysis
from models.identifiability import structural_identifiability
from models.identification import identify
from models.measurement import MeasurementKind
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion
from optimal_design import design_poses
from tests.identification.truth import cramer_rao_rms, nominal_in_true_frame, rms_position_error

NOISE = NoiseModel()
ROBOTS: dict[str, Callable[[], RobotDescription]] = {
    "ur5-dh": ur5_like,
    "iiwa-mdh": iiwa_like,
    "track": track_arm,
    "hexapod": hexapod_alone,
}


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("position_only", [False, True], ids=["pose", "position"])
@pytest.mark.parametrize("name", list(ROBOTS))
def test_identification_reaches_the_cramer_rao_accuracy(name: str, position_only: bool) -> None:
    desc = ROBOTS[name]()
    sim = perturbed_robot(desc, seed=1)
    joints = sample_workspace(desc, 80, seed=11)
    check = sample_workspace(desc, 100, seed=4242)
    result = identify(desc, measure(sim, joints, NOISE, seed=12, position_only=position_only), noise=NOISE)
    assert result.succeeded, result.reason
    kind = MeasurementKind.POSITION if position_only else MeasurementKind.POSE
    structural = structural_identifiability(desc, tuple(range(desc.n_params)), kind)
    assert len(result.estimated) == len(structural.identifiable)
    error = rms_position_error(desc, result.parameters, sim, check)
    bound = cramer_rao_rms(desc, sim, joints, check, np.array(result.estimated), NOISE, position_only=position_only)
    before = rms_position_error(desc, nominal_in_true_frame(desc, sim), sim, check)
    assert error <= 1.3 * bound
    assert before / error >= 20
    assert result.noise_consistent


@pytest.mark.parametrize("name", ["ur5-dh", "iiwa-mdh", "track"])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_compensation_reaches_the_truth(name: str) -> None:
    desc = ROBOTS[name]()
    sim = perturbed_robot(desc, seed=2)
    result = identify(desc, measure(sim, sample_workspace(desc, 80, seed=21), NOISE, seed=22), noise=NOISE)
    assert result.succeeded
    program = sample_workspace(desc, 30, seed=23)
    # Targets where the truth robot puts its TCP for the program; the program's joints seed the answer.
    wanted = forward_kinematics(desc, program, sim.truth)
    answer = inverse_kinematics(
        desc, wanted.positions, matrix_to_quaternion(wanted.rotations), result.parameters, seed=program
    )
    assert answer.reachable.all()
    reached = forward_kinematics(desc, answer.joints, sim.truth).positions
    miss = np.sqrt(np.mean(np.sum((reached - wanted.positions) ** 2, axis=1)))
    assert miss <= 2.5 * result.predicted_accuracy.rms_position_mm
    # the same targets on the nominal model (registered) miss by far more
    nominal = inverse_kinematics(
        desc, wanted.positions, matrix_to_quaternion(wanted.rotations), result.start, seed=program
    )
    nominal_miss = np.linalg.norm(
        forward_kinematics(desc, nominal.joints, sim.truth).positions - wanted.positions, axis=1
    )
    assert np.sqrt(np.mean(nominal_miss**2)) > 10 * miss


GANTRY = {
    "tool": {"position": [0.0, 0.0, -80.0], "orientation": [1.0, 0.0, 0.0, 0.0]},
    "stages": [
        {
            "kind": "serial",
            "convention": "dh",
            "links": [
                {"joint": "prismatic", "a": 0.0, "alpha": -90.0, "d": 0.0, "theta": -90.0, "range": [0, 1200]},
                {"joint": "prismatic", "a": 0.0, "alpha": -90.0, "d": 0.0, "theta": -90.0, "range": [0, 800]},
                {"joint": "prismatic", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "range": [0, 400]},
            ],
        }
    ],
}


@pytest.mark.parametrize("name", [*ROBOTS, "gantry"])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_ik_of_fk_round_trip(name: str) -> None:
    desc = description_from_document(GANTRY, name="gantry") if name == "gantry" else ROBOTS[name]()
    joints = sample_workspace(desc, 40, seed=31)
    fk = forward_kinematics(desc, joints)
    rng = np.random.default_rng(32)
    near = np.clip(
        joints + rng.normal(scale=0.03, size=joints.shape) * (desc.joint_max - desc.joint_min),
        desc.joint_min,
        desc.joint_max,
    )
    # A 3-axis gantry (fewer than six joints) reaches positions; the others whole poses.
    quats = None if desc.n_joints < 6 else matrix_to_quaternion(fk.rotations)
    answer = inverse_kinematics(desc, fk.positions, quats, seed=near)
    assert answer.reachable.all(), [r for r in answer.reasons if r]
    back = forward_kinematics(desc, answer.joints)
    np.testing.assert_allclose(back.positions, fk.positions, atol=1e-6)
    if quats is not None:
        np.testing.assert_allclose(back.rotations, fk.rotations, atol=1e-8)
    # From the default (mid-range) seed every target is reached too.
    assert inverse_kinematics(desc, fk.positions, quats).reachable.all()


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
@pytest.mark.parametrize("name", ["ur5-dh", "iiwa-mdh", "track"])
def test_ik_from_the_default_seed_reaches_every_target_of_the_truth(name: str) -> None:
    # 50 full poses where a perturbed "true" robot puts its TCP: the IK on that robot's parameters, from the
    # default mid-range seed (far from most answers; several branches), must put the truth's own TCP there.
    desc = ROBOTS[name]()
    truth = perturbed_robot(desc, seed=3).truth
    joints = sample_workspace(desc, 50, seed=33)
    wanted = forward_kinematics(desc, joints, truth)
    answer = inverse_kinematics(desc, wanted.positions, matrix_to_quaternion(wanted.rotations), truth)
    assert answer.reachable.sum() == 50, [r for r in answer.reasons if r]
    back = forward_kinematics(desc, answer.joints, truth)
    np.testing.assert_allclose(back.positions, wanted.positions, atol=1e-6)
    np.testing.assert_allclose(back.rotations, wanted.rotations, atol=1e-8)
    assert np.all(answer.joints >= desc.joint_min - 1e-9) and np.all(answer.joints <= desc.joint_max + 1e-9)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("name", ["iiwa-mdh", "hexapod"])
def test_a_pose_design_beats_random_poses(name: str) -> None:

    desc = ROBOTS[name]()
    design = design_poses(desc, 30, "D", "position", candidate_count=400, seed=5)
    assert design.metrics["log_det"] > design.random_baseline["log_det"]
    assert design.metrics["predicted_rms_tcp_mm"] < design.random_baseline["predicted_rms_tcp_mm"]


def test_the_tolerance_study_applies_to_a_serial_arm() -> None:

    desc = iiwa_like()
    result = error_analysis(desc, n_poses=20, n_draws=20, tolerances=ErrorMagnitudes())
    # No hexapod: the link errors are the whole robot's, and the first-order model follows the exact one.
    whole, links = result.errors["whole"], result.errors["carriage"]
    np.testing.assert_allclose(whole.exact, links.exact, atol=1e-12)
    assert not np.any(result.errors["hexapod"].exact)
    assert np.max(np.abs(whole.exact - whole.first_order)) < 0.1 * np.max(np.abs(whole.exact))
