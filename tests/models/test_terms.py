"""The temperature and load terms: their graphs, units, derivatives and statics against independent truths."""

from __future__ import annotations

import numpy as np
import pytest

from models import Registry, forward_kinematics, iwr, sample_workspace
from models.compensation import compensate
from models.description.examples import ur5_like
from models.description.hexapod import N_LEGS
from models.description.parameters import Kind
from models.description.terms import GRAVITY_M_S2, ModelTerms, condition_inputs, make_conditions
from models.errors import InvalidInput
from models.kinematics import inverse_hexapod
from models.transforms import matrix_to_quaternion, rotvec_to_matrix_np

BOTH = ModelTerms(thermal=True, compliance=True)
N = 6


@pytest.fixture(scope="module")
def desc():  # type: ignore[no-untyped-def]
    return iwr().with_terms(BOTH)


@pytest.fixture(scope="module")
def joints() -> np.ndarray:
    return sample_workspace(iwr(), N, seed=7)


@pytest.fixture(scope="module")
def conditions():  # type: ignore[no-untyped-def]
    return make_conditions(N, [15.0, 20.0, 24.0, 28.0, 31.0, 18.0], [0.0, 40.0, 40.0, 10.0, 40.0, 25.0], [20, -30, 120])


def test_terms_off_leave_the_structure_and_its_graphs() -> None:
    plain = iwr()
    assert plain.structure == tuple(link.joint for link in plain.links)
    assert plain.n_params == 70 and "thermal" not in plain.parameters.groups
    fn = Registry().runtime(plain).kinematics.functions
    assert "conditions" not in fn["residual_jacobian_at"].name_in()
    with_terms = plain.with_terms(BOTH)
    assert with_terms.structure != plain.structure and with_terms.geometric_structure == plain.structure
    assert with_terms.parameters.names[:70] == plain.parameters.names
    assert with_terms.parameters.names[70:] == (
        "thermal.legs",
        "thermal.axes",
        *(f"compliance.leg{i + 1}" for i in range(N_LEGS)),
    )


def test_units_convert_in_the_kinds() -> None:
    assert Kind.THERMAL.boundary_unit == "ppm/K" and Kind.THERMAL.to_boundary == 1e6
    assert Kind.COMPLIANCE.boundary_unit == "µm/N" and Kind.COMPLIANCE.to_boundary == 1e3
    table = iwr().with_terms(BOTH).parameters
    boundary = table.as_boundary(table.nominal)
    assert boundary[table.index["thermal.legs"]] == pytest.approx(11.7)
    assert boundary[table.index["compliance.leg2"]] == pytest.approx(0.1)


def test_a_term_needs_the_parts_it_acts_on_and_its_conditions() -> None:
    with pytest.raises(InvalidInput) as err:
        ur5_like().with_terms(ModelTerms(thermal=True))
    assert err.value.field == "terms"
    assert ur5_like().with_terms(ModelTerms(compliance=True)).parameters.names[-1] == "compliance.joint6"
    with pytest.raises(InvalidInput) as err:
        condition_inputs(BOTH, make_conditions(3, None, 10.0), 3)
    assert err.value.field == "temperature_c"
    with pytest.raises(InvalidInput) as err:
        condition_inputs(BOTH, make_conditions(3, 20.0), 3)
    assert err.value.field == "payload"


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_derivatives_equal_central_differences(desc, joints, conditions) -> None:  # type: ignore[no-untyped-def]
    theta = desc.parameters.nominal
    jac = forward_kinematics(desc, joints, theta, jacobian=True, conditions=conditions).jacobians
    names = [*desc.term_index, "leg3.offset", "leg5.b.x", "link2.d", "tool.z"]
    for name in names:
        i = desc.parameters.index[name]
        h = desc.parameters.scales[i] * 1e-3
        up, down = theta.copy(), theta.copy()
        up[i] += h
        down[i] -= h
        fd = (
            forward_kinematics(desc, joints, up, conditions=conditions).positions
            - forward_kinematics(desc, joints, down, conditions=conditions).positions
        ) / (2 * h)
        assert np.abs(fd).max() > 0, name
        assert np.abs(fd - jac[:, :3, i]).max() <= 1e-6 * np.abs(fd).max(), name


def test_thermal_legs_expand_by_kappa_and_axes_by_their_travel(joints) -> None:  # type: ignore[no-untyped-def]
    """Closed form: at ΔT every leg's geometric length is (l + δl)(1 + κ ΔT); the carriage's travel scales."""
    desc = iwr().with_terms(ModelTerms(thermal=True))
    theta = desc.parameters.with_values(desc.parameters.nominal, {"thermal.legs": 20e-6, "thermal.axes": 30e-6})
    temps = make_conditions(N, [12.0, 16.0, 20.0, 24.0, 28.0, 35.0])
    fk = forward_kinematics(desc, joints, theta, conditions=temps)
    geometric = inverse_hexapod(iwr(), fk.platforms)  # commanded lengths of the geometric model: |v| - δl
    offsets = np.array(iwr().hexapod.leg_offsets)  # type: ignore[union-attr]
    assert temps.temperature_c is not None
    dt = temps.temperature_c - 20.0
    expected = (joints[:, 4:] + offsets) * (1 + 20e-6 * dt[:, None]) - offsets
    assert np.abs(geometric - expected).max() < 1e-9
    # the carriage: the thermal model at ΔT is the geometric one at scaled prismatic travel and expanded legs
    scaled = joints.copy()
    scaled[:, :2] *= 1 + 30e-6 * dt[:, None]
    scaled[:, 4:] = expected
    plain = forward_kinematics(iwr(), scaled, theta[:70], check_ranges=False)
    assert np.abs(plain.positions - fk.positions).max() < 1e-8


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_compliance_leg_changes_balance_the_payload_wrench(desc, joints) -> None:  # type: ignore[no-untyped-def]
    """Statics written out in numpy: the leg changes / compliance are tensions whose forces and moments on the
    platform balance the payload's weight at its centre of gravity."""
    only = iwr().with_terms(ModelTerms(compliance=True))
    comp = np.array([0.1, 0.2, 0.3, 0.15, 0.25, 0.12]) * 1e-3
    theta = only.parameters.with_values(
        only.parameters.nominal, {f"compliance.leg{i + 1}": c for i, c in enumerate(comp)}
    )
    cog = np.array([20.0, -30.0, 120.0])
    loads = make_conditions(N, None, 40.0, cog)
    fk = forward_kinematics(only, joints, theta, conditions=loads)
    hexapod = iwr().hexapod
    assert hexapod is not None
    a, b = np.array(hexapod.base_joints), np.array(hexapod.platform_joints)
    offsets = np.array(hexapod.leg_offsets)
    tool = np.asarray(iwr().tool)
    for k in range(N):
        x = fk.platforms[k]
        r = _euler_zyx(*x[3:])
        v = x[:3] + b @ r.T - a  # (6, 3) leg vectors in {4}
        tension = (np.linalg.norm(v, axis=1) - (joints[k, 4:] + offsets)) / comp
        u = v / np.linalg.norm(v, axis=1)[:, None]
        # The carriage's rotation (world <- {4}) from the TCP: R_tcp = R4 R_platform R_tool.
        r_tool = rotvec_to_matrix_np(tool[3:])
        r4 = fk.rotations[k] @ r_tool.T @ r.T
        force = r4.T @ (np.array([0.0, 0.0, -40.0 * GRAVITY_M_S2]))
        cog_world = fk.rotations[k] @ cog + fk.positions[k]
        origin_world = fk.positions[k] - r4 @ r @ tool[:3]
        arm = r4.T @ (cog_world - origin_world)  # cog relative to the platform origin, in {4}
        s = v + a - x[:3]  # R b_i
        assert np.allclose((tension[:, None] * u).sum(axis=0), force, atol=1e-6 * 400)
        assert np.allclose((tension[:, None] * np.cross(s, u)).sum(axis=0), np.cross(arm, force), atol=1e-4 * 400)
        assert np.all(np.abs(tension) < 2000)


def _euler_zyx(alpha: float, beta: float, gamma: float) -> np.ndarray:
    ca, sa, cb, sb, cg, sg = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta), np.cos(gamma), np.sin(gamma)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cg, -sg], [0, sg, cg]])
    return np.asarray(rz @ ry @ rx)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_both_routes_agree(desc, joints, conditions) -> None:  # type: ignore[no-untyped-def]
    """The rootfinder (MX) route and the compiled batch route give the same TCP under the terms."""
    fn = Registry().runtime(desc).kinematics.functions
    theta = desc.parameters.nominal
    batch = forward_kinematics(desc, joints, theta, conditions=conditions)
    inputs = condition_inputs(desc.terms, conditions, N)
    for k in range(N):
        pos, _, _ = fn["fk"](joints[k], theta, desc.platform_home, inputs[k])
        assert np.abs(np.array(pos).ravel() - batch.positions[k]).max() < 1e-9


def test_a_serial_robots_joints_turn_by_compliance_times_the_gravity_torque() -> None:
    """Closed form by virtual work, on the geometric model alone: τ_j = F · ∂p_cog/∂q_j (central differences),
    and the terms' FK at q equals the geometric FK at q + k τ."""
    plain = ur5_like()
    arm = plain.with_terms(ModelTerms(compliance=True))
    names = [f"compliance.joint{j + 1}" for j in range(6)]
    k = np.array([10.0, 30.0, 20.0, 15.0, 25.0, 5.0]) * 1e-6  # rad/(N·m)
    theta = arm.parameters.with_values(arm.parameters.nominal, dict(zip(names, k, strict=True)))
    q = sample_workspace(plain, 4, seed=11)
    cog = np.array([10.0, 20.0, 120.0])
    loads = make_conditions(4, None, 15.0, cog)
    force = np.array([0.0, 0.0, -15.0 * GRAVITY_M_S2])
    got = forward_kinematics(arm, q, theta, conditions=loads).positions

    def cog_world(joints: np.ndarray) -> np.ndarray:
        fk = forward_kinematics(plain, joints, check_ranges=False)
        return np.asarray(np.einsum("nij,j->ni", fk.rotations, cog) + fk.positions)

    h = 1e-6
    torque = np.zeros((4, 6))
    for j in range(6):
        up, down = q.copy(), q.copy()
        up[:, j] += h
        down[:, j] -= h
        torque[:, j] = (cog_world(up) - cog_world(down)) @ force / (2 * h) / 1000.0
    expected = forward_kinematics(plain, q + torque * k, check_ranges=False).positions
    assert np.abs(got - expected).max() < 1e-6
    assert np.abs(got - forward_kinematics(plain, q).positions).max() > 0.05  # the load is visible


def test_compensation_of_a_compliant_arm_reaches_its_targets() -> None:
    arm = ur5_like().with_terms(ModelTerms(compliance=True))
    theta = arm.parameters.with_values(arm.parameters.nominal, {"compliance.joint2": 40e-6, "compliance.joint3": 25e-6})
    q = sample_workspace(ur5_like(), 5, seed=12)
    loads = make_conditions(5, None, [0.0, 5.0, 10.0, 15.0, 20.0], [0.0, 0.0, 100.0])
    target = forward_kinematics(arm, q, theta, conditions=loads)
    sol = compensate(arm, theta, target.positions, matrix_to_quaternion(target.rotations), conditions=loads, seed=q)
    reached = forward_kinematics(arm, sol.joints, theta, conditions=loads, check_ranges=False)
    assert np.linalg.norm(reached.positions - target.positions, axis=1).max() < 1e-8
