"""A UR5 URDF with everything a real description carries (meshes, inertias, limits, dynamics, transmissions,
gazebo tags, a comment, a frame off the chain): the joint origins are those of the UR5 in the public
ur_description package (the old layout: axes along y, quarter-turn pitches); the rest is written for the
test in the same shape, so that the drop-in export can be seen to leave it alone."""

from __future__ import annotations


def _link(name: str, mesh: str, mass: float, com: str, inertia: tuple[float, float, float]) -> str:
    ixx, iyy, izz = inertia
    return f"""  <link name="{name}">
    <visual>
      <geometry><mesh filename="package://ur_description/meshes/ur5/visual/{mesh}.dae"/></geometry>
      <material name="LightGrey"><color rgba="0.7 0.7 0.7 1.0"/></material>
    </visual>
    <collision>
      <geometry><mesh filename="package://ur_description/meshes/ur5/collision/{mesh}.stl"/></geometry>
    </collision>
    <inertial>
      <mass value="{mass}"/>
      <origin xyz="{com}" rpy="0 0 0"/>
      <inertia ixx="{ixx}" ixy="0.0" ixz="0.0" iyy="{iyy}" iyz="0.0" izz="{izz}"/>
    </inertial>
  </link>
"""


def _joint(name: str, kind: str, parent: str, child: str, xyz: str, rpy: str, axis: str, limit: str) -> str:
    moving = kind != "fixed"
    extra = f'    <axis xyz="{axis}"/>\n{limit}    <dynamics damping="0.0" friction="0.0"/>\n' if moving else ""
    return f"""  <joint name="{name}" type="{kind}">
    <parent link="{parent}"/>
    <child link="{child}"/>
    <origin xyz="{xyz}" rpy="{rpy}" />
{extra}  </joint>
"""


def _limit(lo: float, hi: float, effort: float, velocity: float) -> str:
    return f'    <limit lower="{lo}" upper="{hi}" effort="{effort}" velocity="{velocity}"/>\n'


def _transmission(joint: str) -> str:
    return f"""  <transmission name="{joint}_trans">
    <type>transmission_interface/SimpleTransmission</type>
    <joint name="{joint}"><hardwareInterface>hardware_interface/PositionJointInterface</hardwareInterface></joint>
    <actuator name="{joint}_motor"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
"""


ARM_JOINTS = [
    ("shoulder_pan_joint", "revolute", "base_link", "shoulder_link", "0 0 0.089159", "0 0 0", "0 0 1"),
    ("shoulder_lift_joint", "revolute", "shoulder_link", "upper_arm_link", "0 0.13585 0", "0 1.570796325 0", "0 1 0"),
    ("elbow_joint", "revolute", "upper_arm_link", "forearm_link", "0 -0.1197 0.425", "0 0 0", "0 1 0"),
    ("wrist_1_joint", "revolute", "forearm_link", "wrist_1_link", "0 0 0.39225", "0 1.570796325 0", "0 1 0"),
    ("wrist_2_joint", "revolute", "wrist_1_link", "wrist_2_link", "0 0.093 0", "0 0 0", "0 0 1"),
    ("wrist_3_joint", "continuous", "wrist_2_link", "wrist_3_link", "0 0 0.09465", "0 0 0", "0 1 0"),
]
MOVING = [j[0] for j in ARM_JOINTS]
LINKS = [
    ("base_link", "base", 4.0, "0 0 0", (0.0044, 0.0044, 0.0072)),
    ("shoulder_link", "shoulder", 3.7, "0 0 0", (0.0103, 0.0103, 0.0067)),
    ("upper_arm_link", "upperarm", 8.393, "0 0 0.28", (0.2269, 0.2269, 0.0151)),
    ("forearm_link", "forearm", 2.275, "0 0 0.25", (0.0494, 0.0494, 0.0041)),
    ("wrist_1_link", "wrist1", 1.219, "0 0 0", (0.1112, 0.1112, 0.2194)),
    ("wrist_2_link", "wrist2", 1.219, "0 0 0", (0.1112, 0.1112, 0.2194)),
    ("wrist_3_link", "wrist3", 0.1879, "0 0 0", (0.0171, 0.0171, 0.0334)),
]


def ur5_full_urdf() -> str:
    parts = ['<?xml version="1.0" ?>\n', "<!-- ur5: a test description (see tests/service/ur5_full_urdf.py) -->\n"]
    parts.append('<robot name="ur5">\n')
    parts += [_link(*link) for link in LINKS]
    parts += ['  <link name="ee_link"/>\n', '  <link name="tool0"/>\n', '  <link name="base"/>\n']
    for name, kind, parent, child, xyz, rpy, axis in ARM_JOINTS:
        limit = "" if kind == "continuous" else _limit(-6.2831853, 6.2831853, 150.0, 3.15)
        parts.append(_joint(name, kind, parent, child, xyz, rpy, axis, limit))
    parts.append(_joint("ee_fixed_joint", "fixed", "wrist_3_link", "ee_link", "0 0.0823 0", "0 0 1.570796325", "", ""))
    parts.append(
        _joint("wrist_3_link-tool0_fixed_joint", "fixed", "ee_link", "tool0", "0 0 0", "-1.570796325 0 0", "", "")
    )
    parts.append(_joint("base_link-base_fixed_joint", "fixed", "base_link", "base", "0 0 0", "0 0 -3.14159265", "", ""))
    parts += [_transmission(name) for name in MOVING]
    parts.append('  <gazebo reference="shoulder_link"><selfCollide>true</selfCollide></gazebo>\n')
    parts.append('  <gazebo><plugin name="ros_control" filename="libgazebo_ros_control.so"/></gazebo>\n')
    parts.append("</robot>\n")
    return "".join(parts)
