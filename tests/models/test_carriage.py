"""Carriage forward kinematics against the spec's closed form (thesis eqs. 12-14 with a1)."""

from __future__ import annotations

import numpy as np

from models import RobotDescription, default_registry


def test_carriage_matches_closed_form(desc: RobotDescription, rng: np.random.Generator) -> None:
    fk = default_registry().runtime(desc).kinematics["carriage_fk"]
    theta = desc.parameters.nominal
    a1, a3, a4, d3 = 91.0, 252.0, 354.0, 331.0
    for _ in range(200):
        q1, q2 = rng.uniform(0, 800), rng.uniform(0, 300)
        q3, q4 = rng.uniform(0, np.pi), rng.uniform(0, np.pi / 2)
        t = np.array(fk([q1, q2, q3, q4], theta))
        expected = [
            a1 + d3 + a4 * np.sin(q4),
            -q2 - a3 * np.sin(q3) - a4 * np.sin(q3) * np.cos(q4),
            q1 + a3 * np.cos(q3) + a4 * np.cos(q3) * np.cos(q4),
        ]
        np.testing.assert_allclose(t[:3, 3], expected, atol=1e-9)
