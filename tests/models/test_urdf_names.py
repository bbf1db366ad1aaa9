"""A URDF's joint names (the robot's joints as ROS names them, read as campaign columns) and a xacro named as such
(issue 45: a xacro upload answered "the URDF has no link ''")."""

from __future__ import annotations

import pytest

from models.errors import InvalidInput
from models.urdf import document_from_urdf, urdf_joint_names
from tests.models.test_urdf import MOVING, UR5_URDF


def test_the_moving_joints_from_base_to_tip_in_order() -> None:
    assert urdf_joint_names(UR5_URDF, "base_link", "tool0") == tuple(MOVING)
    assert urdf_joint_names(UR5_URDF, "world", "wrist_2_link") == tuple(MOVING[:5])  # fixed joints left out


XACRO_ROOT = '<robot name="ur5" xmlns:xacro="http://ros.org/wiki/xacro">'


def test_a_xacro_is_named_with_its_command() -> None:
    xacro = UR5_URDF.replace('<robot name="ur5">', XACRO_ROOT + '\n<xacro:property name="pi" value="3.14159"/>')
    with pytest.raises(InvalidInput) as raised:
        document_from_urdf(xacro, "", "")
    message = str(raised.value)
    assert "xacro file" in message and "xacro robot.urdf.xacro > robot.urdf" in message
    assert "no link" not in message


@pytest.mark.parametrize("mark", ["<xacro:include filename='arm.xacro'/>", '<link name="${prefix}base"/>'])
def test_a_xacro_element_or_substitution_is_a_xacro(mark: str) -> None:
    with pytest.raises(InvalidInput, match="xacro file"):
        document_from_urdf(UR5_URDF.replace('<robot name="ur5">', XACRO_ROOT + mark), "base_link", "tool0")


def test_an_expanded_urdf_keeping_the_xacro_namespace_is_read() -> None:
    """What `xacro robot.urdf.xacro > robot.urdf` writes keeps `xmlns:xacro` on its root, and its comments may
    quote xacro (TIAGo's URDF in example-robot-data does both): it was refused as a xacro, the very file the
    refusal asks for."""
    expanded = UR5_URDF.replace(
        '<robot name="ur5">', XACRO_ROOT + '\n<!--xacro:caster_transmission name="" side="${side}"-->'
    )
    assert document_from_urdf(expanded, "base_link", "tool0") == document_from_urdf(UR5_URDF, "base_link", "tool0")
