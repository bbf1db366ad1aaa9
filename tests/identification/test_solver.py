"""The solver: converged to far below a micrometre, no graph built per campaign size, validation."""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, RobotDescription, default_registry, forward_kinematics, iwr, sample_workspace
from models.campaign import Campaign
from models.engine import cancellation
from models.engine.runtime import runtime_for
from models.identification import identify, rigid_fit, validate
from models.identification.residuals import CampaignProblem
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion, rotvec_to_matrix_np


def test_solution_is_stationary_to_well_below_a_micrometre(desc: RobotDescription) -> None:
    sim = perturbed_robot(desc, seed=3)
    joints = sample_workspace(desc, 50, seed=5)
    campaign = measure(sim, joints, seed=6)
    result = identify(desc, campaign)
    free = np.array(result.estimated)
    problem = CampaignProblem(desc, default_registry().runtime(desc), campaign, NoiseModel(), result.parameters, free)
    ev = problem.evaluate(np.zeros(free.size))
    assert ev is not None
    step = np.linalg.solve(ev.hessian, -ev.gradient)  # one more Gauss–Newton step from the solution
    moved = result.parameters.copy()
    moved[free] += problem.scales * step
    check = sample_workspace(desc, 50, seed=7)
    shift = (
        forward_kinematics(desc, check, moved).positions - forward_kinematics(desc, check, result.parameters).positions
    )
    assert np.abs(shift).max() < 1e-4  # mm


def test_new_campaign_sizes_build_no_new_solver(desc: RobotDescription) -> None:
    sim = perturbed_robot(desc, seed=4)
    identify(desc, measure(sim, sample_workspace(desc, 40, seed=1), seed=2))
    builds = default_registry().runtime(desc).builds.get("ipopt_solver", 0)
    for n in (33, 47, 71):
        result = identify(desc, measure(sim, sample_workspace(desc, n, seed=n), seed=n))
        assert result.succeeded
        assert result.solver.iterations <= 10
    assert default_registry().runtime(desc).builds.get("ipopt_solver", 0) == builds


def test_validation_on_a_second_campaign_and_after_moving_the_instrument(desc: RobotDescription) -> None:
    sim = perturbed_robot(desc, seed=8)
    result = identify(desc, measure(sim, sample_workspace(desc, 60, seed=9), seed=10))
    second = measure(sim, sample_workspace(desc, 40, seed=11), seed=12)
    report = validate(desc, result.parameters, second)
    truth = forward_kinematics(desc, second.joints, sim.truth).positions
    model = forward_kinematics(desc, second.joints, result.parameters).positions
    expected = np.linalg.norm(model - second.positions, axis=1)
    np.testing.assert_allclose(report.errors.per_pose_mm, expected, rtol=1e-12)
    assert report.errors.rms_mm < 0.1
    assert np.sqrt(np.mean(np.sum((model - truth) ** 2, axis=1))) < report.errors.rms_mm  # noise adds

    # The instrument moved 1 m and turned 10°: without re-registering the errors are ~1 m, with it they are back.
    rot = rotvec_to_matrix_np(np.radians([0.0, 0.0, 10.0]))
    shift = np.array([1000.0, -200.0, 50.0])
    assert second.quaternions is not None
    moved = Campaign(second.joints, second.positions @ rot.T + shift, matrix_to_quaternion(rot @ second.rotations))
    assert validate(desc, result.parameters, moved).errors.rms_mm > 100
    again = validate(desc, result.parameters, moved, register=True)
    assert again.registered
    assert again.errors.rms_mm == pytest.approx(report.errors.rms_mm, rel=0.05)
    assert rigid_fit(second.positions, moved.positions).rms_mm < 1e-9


def test_each_ipopt_iteration_is_told_with_an_eta_from_the_solver_s_past_solves() -> None:
    """A job's progress: the current token hears of every iteration (its number, the median iteration count
    of the solver's past solves, the time so far), and the ETA is the remaining iterations at this pace."""
    desc = iwr()
    campaign = measure(perturbed_robot(desc, seed=3), sample_workspace(desc, 30, seed=3), seed=4)
    heard: list[cancellation.Step] = []
    runtime = runtime_for(desc)
    for _ in range(2):
        with cancellation.cancellable(cancellation.CancellationToken(on_step=heard.append)):
            result = identify(desc, campaign, runtime=runtime)
    first = [s for s in heard if s.iteration == 1]
    assert len(first) >= 2 and [s.iteration for s in heard[: result.solver.iterations]] == list(
        range(1, result.solver.iterations + 1)
    )
    later = heard[-1]
    assert later.expected is not None and later.expected >= 1 and later.seconds > 0
    assert cancellation.Step(2, 10, 1.0).eta_seconds == pytest.approx(4.0)  # 8 left at 0.5 s each
    assert cancellation.Step(12, 10, 1.2).eta_seconds == pytest.approx(0.1)  # past the typical: one more
    assert cancellation.Step(3, None, 1.0).eta_seconds is None
