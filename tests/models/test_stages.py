"""The stage seam: a robot is any chain of stage objects, and the symbolic model composes them unasked.

The proof is a robot no document can describe today, two hexapods with a serial part between them and after
them, checked against a hand-written numpy model (DH products and platform transforms from the sampled platform
poses) and its identification Jacobian against central finite differences.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import RobotDescription, forward_kinematics, sample_workspace, solve_platforms
from models.description.iwr import IWR_HEXAPOD, iwr
from models.description.parameters import Kind
from models.description.serial_chain import DHLink, JointType
from models.description.structure import description_document, description_from_document
from models.description.terms import ModelTerms
from models.errors import InvalidInput
from models.stages import HexapodStage, SerialStage
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

_DEG = math.pi / 180
SMALL = HexapodStage(
    IWR_HEXAPOD.__class__(
        base_joints=tuple((0.5 * a, 0.5 * b, c) for a, b, c in IWR_HEXAPOD.base_joints),
        platform_joints=tuple((0.5 * a, 0.5 * b, c) for a, b, c in IWR_HEXAPOD.platform_joints),
        leg_offsets=(0.0,) * 6,
        stroke_min=185.0,
        stroke_max=275.0,
        home=(0.0, 0.0, 200.0, 0.0, 0.0, 0.0),
        workspace_min=(-20.0, -20.0, 180.0, -5 * _DEG, -5 * _DEG, -5 * _DEG),
        workspace_max=(20.0, 20.0, 220.0, 5 * _DEG, 5 * _DEG, 5 * _DEG),
        max_condition=100.0,
    )
)
TWO_HEXAPODS = RobotDescription(
    name="two-hexapods",
    stages=(
        SerialStage(
            (
                DHLink(JointType.PRISMATIC, theta=0.0, d=0.0, a=91.0, alpha=90 * _DEG, joint_min=0.0, joint_max=800.0),
                DHLink(JointType.REVOLUTE, theta=0.0, d=331.0, a=252.0, alpha=0.0, joint_min=0.0, joint_max=math.pi),
            )
        ),
        HexapodStage(IWR_HEXAPOD),
        SerialStage(
            (DHLink(JointType.REVOLUTE, theta=0.0, d=50.0, a=120.0, alpha=90 * _DEG, joint_min=-1.0, joint_max=1.0),)
        ),
        SMALL,
    ),
    base=(10.0, -20.0, 30.0, 0.01, -0.02, 0.03),
    tool=(5.0, 0.0, 80.0, 0.0, 0.1, 0.0),
)


def _dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]])


def _pose(p: np.ndarray) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rotvec_to_matrix_np(p[3:6]), p[:3]
    return t


def _platform(x: np.ndarray) -> np.ndarray:
    a, b, g = x[3:6]
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rx = np.array([[1, 0, 0], [0, math.cos(g), -math.sin(g)], [0, math.sin(g), math.cos(g)]])
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rz @ ry @ rx, x[:3]
    return t


def _reference_tcp(desc: RobotDescription, q: np.ndarray, x: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """The robot written out by hand: base · DH(q1) · DH(q2) · platform 1 · DH(q3) · platform 2 · tool."""
    index = desc.parameters.index

    def link(k: int, joint: float, prismatic: bool) -> np.ndarray:
        th, d, a, al = (theta[index[f"link{k}.{f}"]] for f in ("theta", "d", "a", "alpha"))
        return _dh(th, d + joint, a, al) if prismatic else _dh(th + joint, d, a, al)

    t = _pose(theta[desc.slices["base"]]) @ link(1, q[0], True) @ link(2, q[1], False)
    t = t @ _platform(x[0:6]) @ link(3, q[2], False) @ _platform(x[6:12])
    return np.asarray(t @ _pose(theta[desc.slices["tool"]]))


def test_layout_keeps_serial_joints_and_link_parameters_before_the_legs() -> None:
    d = TWO_HEXAPODS
    assert d.joint_names == ("q1", "q2", "q3", *(f"l{i}" for i in range(1, 13)))
    assert d.n_joints == 15 and d.n_chain == 3 and d.n_unknowns == 12 and d.n_platform == 12
    names = d.parameters.names
    assert names[:6] == tuple(f"base.{a}" for a in ("x", "y", "z", "rx", "ry", "rz"))
    assert names[6:18] == tuple(f"link{k}.{f}" for k in (1, 2, 3) for f in ("theta", "d", "a", "alpha"))
    assert names[18] == "leg1.a.x" and names[18 + 42] == "leg7.a.x" and names[-6] == "tool.x"
    assert d.n_params == 6 + 12 + 84 + 6
    # The IWR is laid out exactly as before: 70 parameters, the carriage and hexapod groups.
    assert iwr().n_params == 70 and iwr().parameters.names[6] == "link1.theta"
    assert iwr().slices["hexapod"] == slice(22, 64)


def test_two_hexapods_forward_kinematics_match_a_hand_written_model() -> None:
    d = TWO_HEXAPODS
    theta = d.parameters.nominal.copy()
    theta += np.random.default_rng(4).normal(0.0, 0.05, theta.size)  # off nominal: every parameter counts
    joints, platforms = sample_workspace(d, 6, seed=3, params=theta, return_platforms=True)
    assert joints.shape == (6, 15) and platforms.shape == (6, 12)
    solved, closure = solve_platforms(d, joints, theta)
    np.testing.assert_allclose(solved, platforms, atol=1e-8)  # each platform found from its own legs
    assert np.all(closure < 1e-9)
    fk = forward_kinematics(d, joints, theta)
    for k in range(joints.shape[0]):
        ref = _reference_tcp(d, joints[k], platforms[k], theta)
        np.testing.assert_allclose(fk.positions[k], ref[:3, 3], atol=1e-8)
        np.testing.assert_allclose(fk.rotations[k], ref[:3, :3], atol=1e-11)


def test_two_hexapods_identification_jacobian_matches_finite_differences() -> None:
    d = TWO_HEXAPODS
    theta = d.parameters.nominal
    joints = sample_workspace(d, 3, seed=8)
    ad = forward_kinematics(d, joints, theta, jacobian=True).jacobians
    for j, spec in enumerate(d.parameters.specs):
        h = 1e-4 if spec.kind is Kind.LENGTH else 1e-6
        plus, minus = theta.copy(), theta.copy()
        plus[j] += h
        minus[j] -= h
        fp, fm = forward_kinematics(d, joints, plus), forward_kinematics(d, joints, minus)
        fd = np.concatenate(
            [
                (fp.positions - fm.positions) / (2 * h),
                matrix_to_rotvec_np(np.einsum("nij,nkj->nik", fp.rotations, fm.rotations)) / (2 * h),
            ],
            axis=1,
        )
        scale = max(float(np.linalg.norm(fd)), 1.0)
        assert np.linalg.norm(ad[:, :, j] - fd) <= 1e-6 * scale, spec.name


def test_a_hexapod_between_serial_parts_reads_and_writes_its_document() -> None:
    doc = description_document(iwr())
    arm = {"kind": "serial", "convention": "dh", "links": [dict(doc["stages"][0]["links"][2])]}
    hybrid = {**doc, "stages": [doc["stages"][0], doc["stages"][1], arm]}
    d = description_from_document(hybrid)
    assert d.hexapod_at == 4 and d.n_chain == 5 and d.joint_names[4:6] == ("q5", "l1")
    again = description_from_document(description_document(d))
    assert again.parameters.names == d.parameters.names
    np.testing.assert_allclose(again.parameters.nominal, d.parameters.nominal, atol=1e-12)


def test_documents_keep_the_contracts_single_hexapod_and_terms_refuse_two() -> None:
    doc = description_document(iwr())
    with pytest.raises(InvalidInput) as err:
        description_from_document({**doc, "stages": [doc["stages"][1], doc["stages"][1]]})
    assert err.value.field == "stages[1].kind"
    with pytest.raises(InvalidInput) as err:
        TWO_HEXAPODS.with_terms(ModelTerms(thermal=True))
    assert err.value.field == "terms"
