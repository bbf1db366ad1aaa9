"""Closed-form registration against known rigid transforms."""

from __future__ import annotations

import numpy as np
import pytest

from models.errors import InvalidInput
from models.identification import rigid_fit
from models.transforms import rotvec_to_matrix_np


def test_recovers_a_known_transform_exactly(rng: np.random.Generator) -> None:
    points = rng.normal(scale=500.0, size=(40, 3))
    rotation = rotvec_to_matrix_np(rng.normal(size=3))
    translation = rng.normal(scale=3000.0, size=3)
    fit = rigid_fit(points, points @ rotation.T + translation)
    np.testing.assert_allclose(fit.rotation, rotation, atol=1e-12)
    np.testing.assert_allclose(fit.translation, translation, atol=1e-8)
    assert fit.rms_mm < 1e-9


def test_never_returns_a_reflection(rng: np.random.Generator) -> None:
    points = rng.normal(scale=100.0, size=(20, 3))
    mirrored = points * np.array([1.0, 1.0, -1.0])
    fit = rigid_fit(points, mirrored)
    assert np.linalg.det(fit.rotation) == pytest.approx(1.0)
    assert fit.rms_mm > 1.0


def test_collinear_points_are_refused() -> None:
    line = np.outer(np.linspace(0, 100, 10), [1.0, 2.0, 3.0])
    with pytest.raises(InvalidInput, match="collinear"):
        rigid_fit(line, line + 5.0)
