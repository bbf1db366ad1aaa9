"""An interferometer's line (`models.measurements.line`, the displacement record kind): its residuals' derivatives
against finite differences of the robot's own forward kinematics and of its unknowns, its closed-form start
against the line the records were made on, and the short travel it refuses."""

from __future__ import annotations

import numpy as np
import pytest

from harness.ballbar import reaching
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.errors import InvalidInput
from models.measurements.line import Line
from tests.reference_differences import residual_differences

DESC = ur5_like()
DIRECTION = np.array([0.6, 0.0, 0.8])
ORIGIN = np.array([380.0, -120.0, 260.0])


@pytest.mark.slow  # 2 x 48 forward kinematics with their Jacobians: ~0.4 s
def test_the_residuals_derivatives_are_those_of_the_forward_kinematics() -> None:
    """∂r/∂θ by central differences of the model's FK over every parameter, ∂r/∂(α, β, h) by differences of u."""
    theta = DESC.parameters.nominal.copy()
    joints = sample_workspace(DESC, 5, seed=3)
    line = Line("l1", (0.3, -0.2, 0.9), (100.0, 50.0, 0.0))
    u = np.array([0.02, -0.01, 110.0, 40.0, 12.5])
    values = np.linspace(-40.0, 40.0, 5)
    tcp = forward_kinematics(DESC, joints, theta, jacobian=True)
    r, d_theta, d_u = line.residuals(tcp, u, values)
    assert r.shape == (5, 4) and d_theta.shape == (5, 4, theta.size) and d_u.shape == (5, 4, 5)
    by_theta, by_u = residual_differences(line, DESC, joints, theta, u, values, h_u=1e-7)
    np.testing.assert_allclose(d_theta, by_theta, atol=2e-6)
    np.testing.assert_allclose(d_u, by_u, rtol=1e-6, atol=1e-5)


def test_the_residual_is_the_reading_model_written_independently() -> None:
    """At α = β = 0 the direction is the start's unit vector: the reading's row n₀ · (p − o) − s and the rows across
    the beam, the TCP's offset from its nearest point of the beam, by hand."""
    theta = DESC.parameters.nominal
    joints = sample_workspace(DESC, 4, seed=5)
    tcp = forward_kinematics(DESC, joints, theta, jacobian=True)
    values = np.array([1.0, -2.0, 3.0, 0.5])
    origin = np.array([7.0, -3.0, 2.0])
    r, _, _ = Line("l1", (0.0, 3.0, 4.0)).residuals(tcp, np.array([0.0, 0.0, *origin]), values)
    n = np.array([0.0, 0.6, 0.8])
    for k, p in enumerate(tcp.positions):
        along = float((p - origin) @ n)
        nearest = origin + along * n
        assert r[k, 0] == pytest.approx(along - values[k], abs=1e-12)
        np.testing.assert_allclose(r[k, 1:], p - nearest, atol=1e-12)


def test_the_start_is_the_line_the_records_were_made_on() -> None:
    theta = DESC.parameters.nominal
    travel = np.linspace(-120.0, 120.0, 9)
    joints = reaching(DESC, theta, ORIGIN + travel[:, None] * DIRECTION, 1)
    p = forward_kinematics(DESC, joints, theta).positions
    readings = (p - ORIGIN) @ DIRECTION  # the reading's zero at ORIGIN
    started = Line("l1", (0.0, 0.0, 1.0)).started(forward_kinematics(DESC, joints, theta), readings)
    np.testing.assert_allclose(started.direction, DIRECTION, atol=1e-9)
    np.testing.assert_allclose(started.origin, ORIGIN, atol=1e-8)
    # read the other way, the line points the other way
    backwards = Line("l1", (0.0, 0.0, 1.0)).started(forward_kinematics(DESC, joints, theta), -readings)
    np.testing.assert_allclose(backwards.direction, -DIRECTION, atol=1e-9)


def test_records_that_do_not_travel_along_the_beam_are_refused_naming_the_line() -> None:
    theta = DESC.parameters.nominal
    joints = reaching(DESC, theta, ORIGIN + np.zeros((6, 3)), 2)
    with pytest.raises(InvalidInput, match="line 'l1': the records spread"):
        Line("l1", (0.0, 0.0, 1.0)).started(forward_kinematics(DESC, joints, theta), np.zeros(joints.shape[0]))
