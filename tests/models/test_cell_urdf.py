"""A URDF's <collision> shapes on the model's frames (models.cell.urdf_geometry), against yourdfpy's own FK."""

from __future__ import annotations

import io

import numpy as np
import yourdfpy

from models.cell import (
    Attached,
    Box,
    Cylinder,
    Sphere,
    cell_for,
    check_poses,
    frame_layout,
    stage_frames,
    urdf_geometry,
)
from models.description.structure import description_from_document
from models.formats.urdf import document_from_urdf
from models.workspace import sample_workspace

# The UR5's joint origins of the public ur_description (the old layout: axes along y, quarter-turn pitches), its
# links' collision written as primitives the way simplified descriptions do (a cylinder per link segment, origin
# and rpy placing it), one box, one sphere and one mesh, which is not read.
JOINTS = [
    ("shoulder_pan_joint", "base_link", "shoulder_link", "0 0 0.089159", "0 0 0", "0 0 1"),
    ("shoulder_lift_joint", "shoulder_link", "upper_arm_link", "0 0.13585 0", "0 1.570796325 0", "0 1 0"),
    ("elbow_joint", "upper_arm_link", "forearm_link", "0 -0.1197 0.425", "0 0 0", "0 1 0"),
    ("wrist_1_joint", "forearm_link", "wrist_1_link", "0 0 0.39225", "0 1.570796325 0", "0 1 0"),
    ("wrist_2_joint", "wrist_1_link", "wrist_2_link", "0 0.093 0", "0 0 0", "0 0 1"),
    ("wrist_3_joint", "wrist_2_link", "wrist_3_link", "0 0 0.09465", "0 0 0", "0 1 0"),
]
COLLISIONS = {
    "base_link": '<geometry><cylinder radius="0.075" length="0.04"/></geometry><origin xyz="0 0 0.02" rpy="0 0 0"/>',
    "shoulder_link": '<geometry><cylinder radius="0.06" length="0.15"/></geometry><origin xyz="0 0 0" rpy="0 0 0"/>',
    "upper_arm_link": '<geometry><cylinder radius="0.055" length="0.425"/></geometry>'
    '<origin xyz="0 0 0.2125" rpy="0 0 0"/>',
    "forearm_link": '<geometry><cylinder radius="0.045" length="0.392"/></geometry>'
    '<origin xyz="0 0 0.196" rpy="0 0 0"/>',
    "wrist_1_link": '<geometry><box size="0.08 0.1 0.08"/></geometry><origin xyz="0 0.05 0" rpy="0.3 0 0"/>',
    "wrist_2_link": '<geometry><sphere radius="0.05"/></geometry><origin xyz="0 0 0.05" rpy="0 0 0"/>',
    "wrist_3_link": '<geometry><mesh filename="package://ur_description/meshes/ur5/collision/wrist3.stl"/></geometry>',
}


def ur5_urdf() -> str:
    parts = ['<?xml version="1.0" ?>\n<robot name="ur5">\n']
    for link, collision in COLLISIONS.items():
        parts.append(f'  <link name="{link}">\n    <collision>{collision}</collision>\n  </link>\n')
    parts.append('  <link name="ee_link"/>\n')
    for name, parent, child, xyz, rpy, axis in JOINTS:
        parts.append(
            f'  <joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
            '<limit lower="-6.2831853" upper="6.2831853" effort="150" velocity="3.15"/></joint>\n'
        )
    parts.append(
        '  <joint name="ee_fixed_joint" type="fixed"><parent link="wrist_3_link"/><child link="ee_link"/>'
        '<origin xyz="0 0.0823 0" rpy="0 0 1.570796325"/></joint>\n</robot>\n'
    )
    return "".join(parts)


def test_urdf_shapes_sit_where_the_urdf_puts_them() -> None:
    text = ur5_urdf()
    desc = description_from_document(document_from_urdf(text, "base_link", "ee_link"), name="ur5-urdf")
    geometry = urdf_geometry(desc, text, "base_link", "ee_link")
    attached = [s for s in geometry.shapes if isinstance(s, Attached)]
    assert [type(s.shape) for s in attached] == [Cylinder] * 4 + [Box, Sphere]
    assert geometry.skipped == ("wrist_3_link: package://ur_description/meshes/ur5/collision/wrist3.stl",)
    assert attached[2].shape == Cylinder(55.0, 425.0)
    # Where the model puts each shape at random joints = where yourdfpy's FK puts it (base_link <- link · origin)
    urdf = yourdfpy.URDF.load(io.BytesIO(text.encode()), load_meshes=False, load_collision_meshes=False)
    links = ["base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link"]
    names = frame_layout(desc).names
    q = sample_workspace(desc, 5, seed=2)
    frames = stage_frames(desc, q)
    for k in range(q.shape[0]):
        urdf.update_cfg(q[k])
        for shape, link in zip(attached, links, strict=True):
            model = frames[k, names.index(shape.frame)] @ shape.matrix
            expected = urdf.get_transform(link, "base_link") @ urdf.link_map[link].collisions[0].origin
            expected[:3, 3] *= 1000.0
            np.testing.assert_allclose(model, expected, atol=1e-6)


def test_a_urdf_cell_checks_its_poses() -> None:
    text = ur5_urdf()
    desc = description_from_document(document_from_urdf(text, "base_link", "ee_link"), name="ur5-urdf")
    cell = cell_for(desc, geometry=urdf_geometry(desc, text, "base_link", "ee_link"))
    # Folded back on itself: the forearm's cylinder through the base's and the shoulder's
    folded = np.array([[0.0, -np.pi / 2, 3.0, 0.0, 0.0, 0.0]])
    straight = np.array([[0.0, -np.pi / 2, 0.0, 0.0, 0.0, 0.0]])  # upright
    assert check_poses(desc, cell, straight).feasible.all()
    assert check_poses(desc, cell, folded).reasons == ("self_collision",)
