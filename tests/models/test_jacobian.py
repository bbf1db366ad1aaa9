"""The identification Jacobian against central finite differences, all 70 parameters."""

from __future__ import annotations

import numpy as np
import pytest

from models import RobotDescription, default_registry, forward_kinematics, sample_workspace
from models.description.parameters import Kind
from models.simulation import perturbed_robot
from models.transforms import matrix_to_rotvec_np


def _steps(desc: RobotDescription) -> np.ndarray:
    # Central differences: error ~ h² f''' + eps |f| / h; these steps balance both for mm and rad.
    return np.array([1e-4 if s.kind is Kind.LENGTH else 1e-6 for s in desc.parameters.specs])


def _finite_difference_jacobian(desc: RobotDescription, joints: np.ndarray, theta: np.ndarray) -> np.ndarray:
    base = forward_kinematics(desc, joints, theta)
    jac = np.zeros((joints.shape[0], 6, desc.n_params))
    for j, h in enumerate(_steps(desc)):
        plus, minus = theta.copy(), theta.copy()
        plus[j] += h
        minus[j] -= h
        fp, fm = forward_kinematics(desc, joints, plus), forward_kinematics(desc, joints, minus)
        jac[:, :3, j] = (fp.positions - fm.positions) / (2 * h)
        # small world-frame rotation: log(R(θ+h) R(θ-h)ᵀ) / 2h
        rel = np.einsum("nij,nkj->nik", fp.rotations, fm.rotations)
        jac[:, 3:, j] = matrix_to_rotvec_np(rel) / (2 * h)
        assert np.allclose(base.positions, (fp.positions + fm.positions) / 2, atol=1e-3)
    return jac


def _assert_columns_close(ad: np.ndarray, fd: np.ndarray, rtol: float) -> None:
    for j in range(ad.shape[-1]):
        a, f = ad[..., j], fd[..., j]
        scale = max(float(np.linalg.norm(f)), 1.0)
        assert np.linalg.norm(a - f) <= rtol * scale, f"parameter {j}: |AD - FD| = {np.linalg.norm(a - f):.3g}"


@pytest.mark.parametrize("which", ["nominal", "perturbed"])
def test_identification_jacobian_matches_finite_differences(desc: RobotDescription, which: str) -> None:
    theta = desc.parameters.nominal if which == "nominal" else perturbed_robot(desc, 3).truth
    joints = sample_workspace(desc, 8, seed=21)
    ad = forward_kinematics(desc, joints, theta, jacobian=True).jacobians
    assert ad is not None
    _assert_columns_close(ad, _finite_difference_jacobian(desc, joints, theta), rtol=1e-6)


def test_rootfinder_route_equals_explicit_implicit_function_theorem(desc: RobotDescription) -> None:
    """CasADi's AD through `rootfinder` and our explicit IFT give the same Jacobian."""
    fns = default_registry().runtime(desc).kinematics
    theta = perturbed_robot(desc, 5).truth
    joints = sample_workspace(desc, 5, seed=2)
    batch = forward_kinematics(desc, joints, theta, jacobian=True)
    assert desc.hexapod is not None
    for k, q in enumerate(joints):
        position, rotation, _, jac = fns["fk_jacobian"](q, theta, desc.hexapod.home)
        np.testing.assert_allclose(np.array(position).ravel(), batch.positions[k], atol=1e-9)
        np.testing.assert_allclose(np.array(rotation), batch.rotations[k], atol=1e-12)
        np.testing.assert_allclose(np.array(jac), batch.jacobians[k], rtol=1e-9, atol=1e-9)


def test_residual_jacobian_matches_finite_differences(desc: RobotDescription) -> None:
    fns = default_registry().runtime(desc).kinematics
    sim = perturbed_robot(desc, 9)
    joints = sample_workspace(desc, 3, seed=4)
    fk = forward_kinematics(desc, joints, sim.truth)
    theta = sim.nominal.copy()
    theta[desc.slices["base"]] = sim.truth[desc.slices["base"]]  # registered: residuals small but not zero
    platforms = forward_kinematics(desc, joints, theta).platforms
    res, jac = fns.batch("residual_jacobian_at", joints, theta, platforms, fk.positions, fk.rotations)
    for j, h in enumerate(_steps(desc)):
        plus, minus = theta.copy(), theta.copy()
        plus[j] += h
        minus[j] -= h
        rp = fns.batch(
            "residual_at", joints, plus, forward_kinematics(desc, joints, plus).platforms, fk.positions, fk.rotations
        )[0]
        rm = fns.batch(
            "residual_at", joints, minus, forward_kinematics(desc, joints, minus).platforms, fk.positions, fk.rotations
        )[0]
        fd = (rp - rm) / (2 * h)
        assert np.linalg.norm(jac[:, :, j] - fd) <= 1e-6 * max(float(np.linalg.norm(fd)), 1.0), desc.parameters.names[j]
    assert np.abs(res[:, :3]).max() > 0.1  # the nominal model really is off
