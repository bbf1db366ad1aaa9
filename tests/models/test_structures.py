"""Robots of any structure (shared/spec/robots.md): FK against hand-written numpy references of each
convention, the AD Jacobians against central differences, documents read back, names and counts."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from models import forward_kinematics, iwr
from models.description.examples import (
    hexapod_alone,
    iiwa_like,
    iiwa_like_document,
    track_arm,
    ur5_like,
    ur5_like_document,
)
from models.description.robot import RobotDescription
from models.description.structure import description_document, description_from_document
from models.engine.runtime import Registry
from models.transforms import rotvec_to_matrix_np
from models.workspace import sample_workspace

ROBOTS: dict[str, Callable[[], RobotDescription]] = {
    "ur5": ur5_like,
    "ur5-dh-beta": lambda: ur5_like("dh-beta"),
    "iiwa": iiwa_like,
    "track": track_arm,
    "hexapod": hexapod_alone,
    "iwr": iwr,
}


# ----------------------------------------------------------------- independent references, plain numpy
def _rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _ry(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _t(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = [x, y, z]
    return m


def _pose(p6: np.ndarray) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotvec_to_matrix_np(p6[3:])
    m[:3, 3] = p6[:3]
    return m


def reference_serial_fk(desc: RobotDescription, q: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """T = base · Π A_i · tool, written from the textbook definitions of DH and Craig's MDH."""
    index = desc.parameters.index
    t = _pose(theta[desc.slices["base"]])
    k = 0
    for i, link in enumerate(desc.links, start=1):
        th, d, a, al = (theta[index[f"link{i}.{f}"]] for f in ("theta", "d", "a", "alpha"))
        if link.joint.value == "revolute":
            th += q[k]
        elif link.joint.value == "prismatic":
            d += q[k]
        k += link.joint.moves
        beta = theta[index[f"link{i}.beta"]] if f"link{i}.beta" in index else 0.0
        if link.convention.value == "dh":  # Hayati's form when the link carries beta
            t = t @ _rz(th) @ _t(0, 0, d) @ _t(a, 0, 0) @ _rx(al) @ _ry(beta)
        else:
            t = t @ _rx(al) @ _ry(beta) @ _t(a, 0, 0) @ _rz(th) @ _t(0, 0, d)
    return np.asarray(t @ _pose(theta[desc.slices["tool"]]))


def _perturbed(desc: RobotDescription, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return desc.parameters.nominal + rng.normal(size=desc.n_params) * desc.parameters.scales


@pytest.mark.parametrize("name", ["ur5", "ur5-dh-beta", "iiwa", "track"])
def test_serial_fk_matches_numpy_reference(name: str) -> None:
    desc = ROBOTS[name]()
    theta = _perturbed(desc, 1)  # every parameter off its nominal value, betas included
    q = sample_workspace(desc, 40, seed=2)
    fk = forward_kinematics(desc, q, theta)
    for i in range(q.shape[0]):
        ref = reference_serial_fk(desc, q[i], theta)
        np.testing.assert_allclose(fk.positions[i], ref[:3, 3], atol=1e-9)
        np.testing.assert_allclose(fk.rotations[i], ref[:3, :3], atol=1e-12)


def test_ur5_home_matches_the_datasheet() -> None:
    # At q = 0 the UR5's flange sits at x = a2 + a3, y = -(d4 + d6), z = d1 - d5 (its DH table).
    desc = description_from_document({"stages": ur5_like_document()["stages"]})  # the flange, no probe
    fk = forward_kinematics(desc, np.zeros(6))
    np.testing.assert_allclose(fk.positions[0], [-425.0 - 392.25, -(109.15 + 82.3), 89.159 - 94.65], atol=1e-9)


def test_hexapod_alone_fk_inverts_closed_form_legs() -> None:
    desc = hexapod_alone()
    q, platforms = sample_workspace(desc, 30, seed=3, return_platforms=True)
    fk = forward_kinematics(desc, q)
    hexapod = desc.hexapod
    assert hexapod is not None
    a, b = np.array(hexapod.base_joints), np.array(hexapod.platform_joints)
    for i in range(q.shape[0]):
        z, y, x = platforms[i, 3:]
        r = _rz(z)[:3, :3] @ _ry(y)[:3, :3] @ _rx(x)[:3, :3]
        np.testing.assert_allclose(np.linalg.norm(platforms[i, :3] + b @ r.T - a, axis=1), q[i], atol=1e-9)
        np.testing.assert_allclose(fk.positions[i], platforms[i, :3], atol=1e-8)
        np.testing.assert_allclose(fk.rotations[i], r, atol=1e-10)


@pytest.mark.parametrize("name", list(ROBOTS))
def test_identification_jacobian_matches_central_differences(name: str) -> None:
    desc = ROBOTS[name]()
    theta = _perturbed(desc, 4)
    q = sample_workspace(desc, 3, seed=5)
    jac = forward_kinematics(desc, q, theta, jacobian=True).jacobians
    h = 1e-6
    for j in range(desc.n_params):
        step = np.zeros(desc.n_params)
        step[j] = h
        plus, minus = forward_kinematics(desc, q, theta + step), forward_kinematics(desc, q, theta - step)
        dp = (plus.positions - minus.positions) / (2 * h)
        np.testing.assert_allclose(jac[:, :3, j], dp, atol=1e-5, err_msg=desc.parameters.names[j])
        # small rotation: vee(dR Rᵀ)
        dr = np.einsum("nij,nkj->nik", (plus.rotations - minus.rotations) / (2 * h), plus.rotations)
        w = np.stack([dr[:, 2, 1], dr[:, 0, 2], dr[:, 1, 0]], axis=1)
        np.testing.assert_allclose(jac[:, 3:, j], w, atol=1e-6, err_msg=desc.parameters.names[j])


def test_parameter_names_and_groups_follow_the_spec() -> None:
    desc = iiwa_like()
    names = desc.parameters.names
    assert names[:6] == ("base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz")
    assert names[6:11] == ("link1.theta", "link1.d", "link1.a", "link1.alpha", "link1.beta")  # alpha 0: beta
    assert names[11:15] == ("link2.theta", "link2.d", "link2.a", "link2.alpha")
    assert names[-6:] == ("tool.x", "tool.y", "tool.z", "tool.rx", "tool.ry", "tool.rz")
    assert desc.n_params == 6 + 7 * 4 + 1 + 6
    assert set(desc.parameters.groups) == {"base", "links", "tool"}
    assert desc.parameters.indices(["carriage"]) == desc.parameters.indices(["links"])
    assert desc.parameters.indices(["legs"]) == ()
    assert desc.joint_names == tuple(f"q{i}" for i in range(1, 8))
    assert hexapod_alone().joint_names == ("l1", "l2", "l3", "l4", "l5", "l6")
    assert track_arm().n_joints == 7


def test_the_iwr_is_unchanged_and_one_description_among_many() -> None:
    desc = iwr()
    assert desc.n_params == 70 and desc.n_joints == 10
    assert set(desc.parameters.groups) == {"base", "carriage", "hexapod", "tool"}
    again = description_from_document(description_document(desc))
    assert again.structure == desc.structure
    assert again.parameters.names == desc.parameters.names
    np.testing.assert_allclose(again.parameters.nominal, desc.parameters.nominal, atol=1e-12)
    q = sample_workspace(desc, 10, seed=6)
    np.testing.assert_allclose(forward_kinematics(again, q).positions, forward_kinematics(desc, q).positions, atol=1e-9)


def test_a_hexapod_inside_the_chain() -> None:
    # An arm link, the hexapod, then a fixed tool flange: the hexapod sits between two serial stages.
    doc = {
        "stages": [
            {
                "kind": "serial",
                "convention": "dh",
                "links": [{"joint": "revolute", "a": 100.0, "alpha": 0.0, "d": 50.0, "theta": 0.0, "range": [-90, 90]}],
            },
            hexapod_alone().hexapod and description_document(hexapod_alone())["stages"][0],
            {
                "kind": "serial",
                "convention": "mdh",
                "links": [{"joint": "fixed", "a": 10.0, "alpha": 90.0, "d": 20.0, "theta": 30.0}],
            },
        ]
    }
    desc = description_from_document(doc)
    assert desc.hexapod_at == 1 and desc.n_joints == 7
    assert desc.parameters.names[6:14] == (
        "link1.theta",
        "link1.d",
        "link1.a",
        "link1.alpha",
        "link2.theta",
        "link2.d",
        "link2.a",
        "link2.alpha",
    )
    q, platforms = sample_workspace(desc, 5, seed=7, return_platforms=True)
    fk = forward_kinematics(desc, q)
    theta = desc.parameters.nominal
    for i in range(5):
        z, y, x = platforms[i, 3:]
        hexapod = _t(*platforms[i, :3]) @ _rz(z) @ _ry(y) @ _rx(x)
        ref = (
            _rz(q[i, 0]) @ _t(100.0, 0, 50.0) @ hexapod @ _rx(np.pi / 2) @ _t(10, 0, 0) @ _rz(np.pi / 6) @ _t(0, 0, 20)
        )
        np.testing.assert_allclose(fk.positions[i], ref[:3, 3], atol=1e-8)
    assert np.all(np.isfinite(theta))


def test_documents_round_trip_and_structures_share_runtimes() -> None:
    doc = iiwa_like_document()
    desc = description_from_document(doc)
    assert description_from_document(description_document(desc)).parameters == desc.parameters
    other = dict(doc)
    other["stages"] = [
        dict(doc["stages"][0], links=[dict(link, d=link["d"] + 1.0) for link in doc["stages"][0]["links"]])
    ]
    registry = Registry()
    assert registry.runtime(desc) is registry.runtime(description_from_document(other))  # same structure
    assert registry.runtime(ur5_like()) is not registry.runtime(desc)
    assert len({r().structure for r in ROBOTS.values()}) == len(ROBOTS)


def test_the_same_arm_in_dh_and_mdh_has_the_same_fk() -> None:
    dh, mdh = ur5_like("dh"), ur5_like("mdh")
    q = sample_workspace(dh, 20, seed=8)
    a, b = forward_kinematics(dh, q), forward_kinematics(mdh, q)
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-9)
    np.testing.assert_allclose(a.rotations, b.rotations, atol=1e-12)
