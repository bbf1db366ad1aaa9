"""The controller formats against independent truth: UR's published kinematics file, chains multiplied out here
in numpy from the exported numbers alone, and the readers' refusals naming the key."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
import yaml
import yourdfpy

from models import forward_kinematics, sample_workspace
from models.description.examples import hexapod_alone, iiwa_like, ur5_like
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.joint_chain import joint_chain
from models.formats.ur_kinematics import SEGMENTS, kinematics_yaml, read_kinematics, ur_chain
from models.formats.urdf import CONTINUOUS_RANGE_DEG, document_from_urdf
from models.formats.urdf_calibrated import calibrate_urdf, splice_origins, z_onto
from models.simulation import perturbed_robot
from tests.frames import rot, xyz_rpy
from tests.models.test_urdf import MOVING, UR5_URDF

# ur_description's config/ur5/default_kinematics.yaml (Universal_Robots_ROS2_Description 2.4.5): the nominal UR5
# as the vendor's package writes it, the truth the DH table's export must reproduce.
UR5_DEFAULT_KINEMATICS = """
kinematics:
  shoulder: {x: 0, y: 0, z: 0.089159, roll: 0, pitch: 0, yaw: 0}
  upper_arm: {x: 0, y: 0, z: 0, roll: 1.570796327, pitch: 0, yaw: 0}
  forearm: {x: -0.425, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}
  wrist_1: {x: -0.39225, y: 0, z: 0.10915, roll: 0, pitch: 0, yaw: 0}
  wrist_2: {x: 0, y: -0.09465, z: -1.941303950897609e-11, roll: 1.570796327, pitch: 0, yaw: 0}
  wrist_3: {x: 0, y: 0.0823, z: -1.688001216681175e-11, roll: 1.570796326589793, pitch: 3.141592653589793,
            yaw: 3.141592653589793}
  hash: calib_209549117540498681
"""


def _origin(seg: dict[str, float]) -> np.ndarray:
    """Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll), mm: URDF's reading of an origin, written out here."""
    return xyz_rpy(seg["x"] * 1000.0, seg["y"] * 1000.0, seg["z"] * 1000.0, seg["roll"], seg["pitch"], seg["yaw"])


def test_the_nominal_ur5_exports_as_urs_own_file() -> None:
    chain = ur_chain(joint_chain(ur5_like()))
    ours = yaml.safe_load(kinematics_yaml(chain.origins, ["a header"]))["kinematics"]
    theirs = yaml.safe_load(UR5_DEFAULT_KINEMATICS)["kinematics"]
    assert list(ours) == [*SEGMENTS, "hash"] and ours["hash"].startswith("calib_")
    for name in SEGMENTS:
        # The vendor's file rounds π/2 to 10 digits and leaves 2e-11 m of round-off: 1e-8 m, 1e-9 rad.
        np.testing.assert_allclose(_origin(ours[name])[:3, 3], _origin(theirs[name])[:3, 3], atol=1e-5)
        np.testing.assert_allclose(_origin(ours[name])[:3, :3], _origin(theirs[name])[:3, :3], atol=1e-9)


def test_a_perturbed_arms_file_multiplies_out_to_its_fk() -> None:
    desc = ur5_like()
    truth = perturbed_robot(desc, seed=21).truth
    chain = ur_chain(joint_chain(desc, truth))
    kin = yaml.safe_load(kinematics_yaml(chain.origins, []))["kinematics"]
    q = sample_workspace(desc, 25, seed=22)
    fk = forward_kinematics(desc, q, truth)
    for i, qi in enumerate(q):
        t = chain.world_from_root.copy()
        for name, angle in zip(SEGMENTS, qi, strict=True):
            t = t @ _origin(kin[name]) @ rot(2, angle)
        t = t @ chain.tail
        np.testing.assert_allclose(t[:3, 3], fk.positions[i], atol=1e-9)
        np.testing.assert_allclose(t[:3, :3], fk.rotations[i], atol=1e-12)
    # Read back: the same six origins.
    for mine, read in zip(chain.origins, read_kinematics(kinematics_yaml(chain.origins, [])), strict=True):
        np.testing.assert_allclose(read, mine, atol=1e-12)


def test_only_a_6r_serial_arm_has_a_ur_file() -> None:
    with pytest.raises(InvalidInput) as seven:
        ur_chain(joint_chain(iiwa_like()))
    assert seven.value.field == "format" and seven.value.reason == "not_6r"
    with pytest.raises(InvalidInput) as hexapod:
        joint_chain(hexapod_alone(), what="UR's kinematics file")
    assert hexapod.value.reason == "not_serial" and "UR's kinematics file" in str(hexapod.value)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("kinematics: [1, 2", "document"),
        ("just: text", "document.kinematics"),
        (UR5_DEFAULT_KINEMATICS.replace("  wrist_3:", "  wrist_9:"), "document.kinematics.wrist_9"),
        ("\n".join(UR5_DEFAULT_KINEMATICS.splitlines()[:-3]), "document.kinematics.wrist_3"),
        (
            UR5_DEFAULT_KINEMATICS.replace("roll: 1.570796327, pitch: 0", "roll: a, pitch: 0"),
            "document.kinematics.upper_arm.roll",
        ),
        (UR5_DEFAULT_KINEMATICS.replace("x: -0.425", "x: .nan"), "document.kinematics.forearm.x"),
        (UR5_DEFAULT_KINEMATICS.replace("x: -0.425", "x: yes"), "document.kinematics.forearm.x"),
        (UR5_DEFAULT_KINEMATICS.replace("x: -0.425", "x: " + "9" * 400), "document.kinematics.forearm.x"),
        (UR5_DEFAULT_KINEMATICS.replace("x: -0.425", "x: 2001-13-45"), "document"),
        ("[" * 30_000, "document"),
        (UR5_DEFAULT_KINEMATICS.replace("z: 0.089159", "z: 89.159e+3"), "document.kinematics.shoulder.z"),
        (UR5_DEFAULT_KINEMATICS.replace("x: -0.425, ", ""), "document.kinematics.forearm.x"),
        (UR5_DEFAULT_KINEMATICS.replace("shoulder: {x: 0,", "shoulder: {w: 0, x: 0,"), "document.kinematics.shoulder"),
    ],
)
def test_a_bad_file_names_its_key(text: str, field: str) -> None:
    with pytest.raises(InvalidInput) as caught:
        read_kinematics(text)
    assert caught.value.field == field, caught.value


def test_numbers_read_as_yaml_1_2_writes_them_and_are_written_as_yaml_1_1_reads_them() -> None:
    # yaml-cpp (ur_calibration) may write 1e-05; PyYAML (xacro, and this reader) takes it for a string.
    text = UR5_DEFAULT_KINEMATICS.replace("x: -0.425", "x: -4.25e-1").replace("z: 0.089159", "z: 8.9159E-2")
    assert read_kinematics(text)[0][2, 3] == pytest.approx(89.159)
    assert read_kinematics(text)[2][0, 3] == pytest.approx(-425.0)
    origins = [o.copy() for o in ur_chain(joint_chain(ur5_like())).origins]
    origins[0][0, 3] = 1e-2  # mm: 1e-05 m
    written = kinematics_yaml(origins, [])
    assert "x: 1.0e-05" in written and yaml.safe_load(written)["kinematics"]["shoulder"]["x"] == 1e-05


def test_a_continuous_joint_has_ten_turns_either_way() -> None:
    doc = document_from_urdf(UR5_URDF, "world", "tool0")
    assert doc["stages"][0]["links"][5]["range"] == list(CONTINUOUS_RANGE_DEG) == [-3600.0, 3600.0]
    desc = description_from_document(doc)
    assert math.degrees(desc.joint_max[5]) == pytest.approx(3600.0)


@pytest.mark.parametrize("axis", [[0, 0, 1], [0, 0, -1], [0, 1, 0], [1, 0, 0], [0.3, -0.4, 0.5]])
def test_z_onto_takes_z_onto_the_axis(axis: list[float]) -> None:
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    r = z_onto(a)[:3, :3]
    np.testing.assert_allclose(r @ [0, 0, 1], a, atol=1e-15)
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-15)
    assert np.linalg.det(r) == pytest.approx(1.0)


def test_the_splice_inserts_a_missing_origin_and_keeps_an_end_tag() -> None:
    # wrist_2 with no <origin> (the identity), elbow's written with an end tag: both shapes a URDF may have.
    text = UR5_URDF.replace('<origin xyz="0 0.093 0" rpy="0 0 0"/>', "").replace(
        '<origin xyz="0 -0.1197 0.425" rpy="0 0 0"/>', '<origin xyz="0 -0.1197 0.425" rpy="0 0 0"></origin>'
    )
    desc = description_from_document(document_from_urdf(text, "world", "tool0"))
    truth = perturbed_robot(desc, seed=71).truth
    calibrated = calibrate_urdf(text, "world", "tool0", desc, truth)
    out = splice_origins(text, calibrated.origins, "a note")
    assert "<!-- a note -->\n<robot" in out and "></origin>" in out
    model = yourdfpy.URDF.load(io.BytesIO(out.encode()), load_meshes=False, build_collision_scene_graph=False)
    q = sample_workspace(desc, 10, seed=72)
    fk = forward_kinematics(desc, q, truth)
    for i, qi in enumerate(q):
        model.update_cfg(dict(zip(MOVING, qi, strict=True)))
        t = np.array(model.get_transform(frame_to="tool0", frame_from="world"))
        t[:3, 3] *= 1000.0
        t = calibrated.world_from_base_link @ t @ calibrated.tip_to_tcp
        np.testing.assert_allclose(t[:3, 3], fk.positions[i], atol=1e-9)
        np.testing.assert_allclose(t[:3, :3], fk.rotations[i], atol=1e-12)
