"""URDF import and export, against yourdfpy's own forward kinematics as the independent truth."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import yourdfpy

from models import RobotDescription, forward_kinematics, sample_workspace
from models.description.examples import iiwa_like, track_arm, ur5_like
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.urdf import document_from_urdf, urdf_from_description
from models.identifiability import structural_identifiability
from models.measurement import MeasurementKind
from tests.urdf import Y_AXIS, Z_AXIS, UrdfJoint, urdf_robot

# The UR5 as the public ur_description package describes it (metres, radians): joint origins with y offsets
# and quarter-turn pitches, axes along y, none of them in DH form.
ARM = ("-6.2832", "6.2832", "150", "3.15")
ELBOW = ("-3.1416", "3.1416", "150", "3.15")
WRIST = ("-6.2832", "6.2832", "28", "3.2")
PITCH = "0 1.570796325 0"  # a quarter turn about y
UR5_JOINTS = [
    UrdfJoint("world_joint", "fixed", "world", "base_link", "0.1 -0.2 0.05", rpy="0 0 0.3"),
    UrdfJoint("shoulder_pan_joint", "revolute", "base_link", "shoulder_link", "0 0 0.089159", Z_AXIS, ARM),
    UrdfJoint("shoulder_lift_joint", "revolute", "shoulder_link", "upper_arm_link", "0 0.13585 0", Y_AXIS, ARM, PITCH),
    UrdfJoint("elbow_joint", "revolute", "upper_arm_link", "forearm_link", "0 -0.1197 0.425", Y_AXIS, ELBOW),
    UrdfJoint("wrist_1_joint", "revolute", "forearm_link", "wrist_1_link", "0 0 0.39225", Y_AXIS, WRIST, PITCH),
    UrdfJoint("wrist_2_joint", "revolute", "wrist_1_link", "wrist_2_link", "0 0.093 0", Z_AXIS, WRIST),
    UrdfJoint("wrist_3_joint", "continuous", "wrist_2_link", "wrist_3_link", "0 0 0.09465", Y_AXIS),
    UrdfJoint("ee_fixed_joint", "fixed", "wrist_3_link", "ee_link", "0 0.0823 0", rpy="0 0 1.570796325"),
    UrdfJoint("tool_joint", "fixed", "ee_link", "tool0", "0.05 0.02 0.1", rpy="0.2 -0.1 0.4"),
]
UR5_URDF = urdf_robot("ur5", UR5_JOINTS)
MOVING = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]


def _urdf_fk(text: str, joint_names: list[str], q: np.ndarray, base: str, tip: str, metres: np.ndarray) -> np.ndarray:
    model = yourdfpy.URDF.load(__import__("io").BytesIO(text.encode()), load_meshes=False)
    out = []
    for qi in q:
        model.update_cfg(dict(zip(joint_names, qi * metres, strict=True)))
        out.append(np.array(model.get_transform(frame_to=tip, frame_from=base)))
    return np.array(out)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_import_of_the_ur5_urdf_has_its_fk() -> None:
    desc = description_from_document(document_from_urdf(UR5_URDF, "world", "tool0"), name="ur5-urdf")
    assert desc.n_joints == 6 and all(link.convention.value == "mdh" for link in desc.links)
    q = sample_workspace(desc, 20, seed=1)
    truth = _urdf_fk(UR5_URDF, MOVING, q, "world", "tool0", np.ones(6))
    fk = forward_kinematics(desc, q)
    np.testing.assert_allclose(fk.positions, truth[:, :3, 3] * 1000.0, atol=1e-9)
    np.testing.assert_allclose(fk.rotations, truth[:, :3, :3], atol=1e-12)
    # A complete, minimal parameterisation: Everett-Hsu-Roth's 4·6 + 6.
    pose = structural_identifiability(desc, tuple(range(desc.n_params)), MeasurementKind.POSE)
    assert len(pose.identifiable) == 30


GANTRY_WITH_FIXED = {
    "tool": {"position": [5.0, 0.0, -80.0], "orientation": [0.9, 0.1, 0.3, 0.3]},
    "stages": [
        {
            "kind": "serial",
            "convention": "dh",
            "links": [
                {"joint": "prismatic", "a": 10.0, "alpha": -90.0, "d": 0.0, "theta": -90.0, "range": [0, 1200]},
                {"joint": "fixed", "a": 30.0, "alpha": 20.0, "d": 40.0, "theta": 10.0},
                {"joint": "prismatic", "a": 0.0, "alpha": -90.0, "d": 0.0, "theta": -90.0, "range": [0, 800]},
            ],
        },
        {
            "kind": "serial",
            "convention": "mdh",
            "links": [{"joint": "revolute", "a": 20.0, "alpha": 0.0, "d": 5.0, "theta": 0.0, "range": [-170, 170]}],
        },
    ],
}
SERIAL: dict[str, Callable[[], RobotDescription]] = {
    "ur5-dh": ur5_like,
    "ur5-dh-beta": lambda: ur5_like("dh-beta"),
    "iiwa-mdh": iiwa_like,
    "track": track_arm,
    "gantry-fixed": lambda: description_from_document(GANTRY_WITH_FIXED),
}


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("name", list(SERIAL))
def test_export_fk_equals_the_model(name: str) -> None:
    desc = SERIAL[name]()
    rng = np.random.default_rng(2)
    theta = desc.parameters.nominal + rng.normal(size=desc.n_params) * desc.parameters.scales  # "calibrated"
    text = urdf_from_description(desc, theta, name=name)
    q = sample_workspace(desc, 20, seed=3)
    moving = [f"joint{k}" for k, link in enumerate(desc.links, start=1) if link.joint.moves]
    metres = np.where(np.array([k.value for k in desc.joint_kinds]) == "length", 1e-3, 1.0)
    truth = _urdf_fk(text, moving, q, "world", "tcp", metres)
    fk = forward_kinematics(desc, q, theta)
    np.testing.assert_allclose(fk.positions, truth[:, :3, 3] * 1000.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fk.rotations, truth[:, :3, :3], atol=1e-12)
    # and the exported URDF imports back to the same FK
    again = description_from_document(document_from_urdf(text, "world", "tcp"))
    np.testing.assert_allclose(forward_kinematics(again, q).positions, fk.positions, atol=1e-8)


def test_bad_urdf_requests_name_the_field() -> None:
    for text, base, tip, field in [
        ("<robot", "a", "b", "urdf"),
        (UR5_URDF, "nowhere", "tool0", "base_link"),
        (UR5_URDF, "world", "nowhere", "tip_link"),
        (UR5_URDF, "tool0", "world", "tip_link"),
        (UR5_URDF, "ee_link", "tool0", "tip_link"),  # only a fixed joint between them
    ]:
        with pytest.raises(InvalidInput) as err:
            document_from_urdf(text, base, tip)
        assert err.value.field == field
