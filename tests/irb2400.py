"""ROS-Industrial's ABB IRB 2400 as its support package describes it, shared by the tests of URDF joint names
(tests/service) and of the identifiable subset at the fitted geometry (tests/identification)."""

# ROS-Industrial's ABB IRB 2400 (abb_irb2400_support), its xacro macro expanded: the joint origins, axes and limits
# of that package, link and joint names as it writes them (joint_1 … joint_6, link_1 … link_6, tool0), written
# here without the meshes.
IRB2400_URDF = """<?xml version="1.0"?>
<robot name="abb_irb2400">
  <link name="base_link"/><link name="link_1"/><link name="link_2"/><link name="link_3"/>
  <link name="link_4"/><link name="link_5"/><link name="link_6"/><link name="tool0"/><link name="base"/>
  <joint name="joint_1" type="revolute"><origin xyz="0 0 0" rpy="0 0 0"/>
    <parent link="base_link"/><child link="link_1"/><axis xyz="0 0 1"/>
    <limit lower="-3.1416" upper="3.1416" effort="0" velocity="2.618"/></joint>
  <joint name="joint_2" type="revolute"><origin xyz="0.1 0 0.615" rpy="0 0 0"/>
    <parent link="link_1"/><child link="link_2"/><axis xyz="0 1 0"/>
    <limit lower="-1.7453" upper="1.9199" effort="0" velocity="2.618"/></joint>
  <joint name="joint_3" type="revolute"><origin xyz="0 0 0.705" rpy="0 0 0"/>
    <parent link="link_2"/><child link="link_3"/><axis xyz="0 1 0"/>
    <limit lower="-1.0472" upper="1.1345" effort="0" velocity="2.618"/></joint>
  <joint name="joint_4" type="revolute"><origin xyz="0.258 0 0.135" rpy="0 0 0"/>
    <parent link="link_3"/><child link="link_4"/><axis xyz="1 0 0"/>
    <limit lower="-3.49" upper="3.49" effort="0" velocity="6.2832"/></joint>
  <joint name="joint_5" type="revolute"><origin xyz="0.497 0 0" rpy="0 0 0"/>
    <parent link="link_4"/><child link="link_5"/><axis xyz="0 1 0"/>
    <limit lower="-2.0944" upper="2.0944" effort="0" velocity="6.2832"/></joint>
  <joint name="joint_6" type="revolute"><origin xyz="0.085 0 0" rpy="0 0 0"/>
    <parent link="link_5"/><child link="link_6"/><axis xyz="1 0 0"/>
    <limit lower="-6.9813" upper="6.9813" effort="0" velocity="7.854"/></joint>
  <joint name="joint_6-tool0" type="fixed"><parent link="link_6"/><child link="tool0"/>
    <origin xyz="0 0 0" rpy="0 0 0"/></joint>
  <joint name="base_link-base" type="fixed"><origin xyz="0 0 0" rpy="0 0 0"/>
    <parent link="base_link"/><child link="base"/></joint>
</robot>
"""
# The same package's macro file as it is: what a user uploads before expanding it.
IRB2400_XACRO = """<?xml version="1.0"?>
<robot xmlns:xacro="http://ros.org/wiki/xacro">
<xacro:macro name="abb_irb2400" params="prefix">
    <link name="${prefix}base_link"/>
    <link name="${prefix}link_1"/>
    <joint name="${prefix}joint_1" type="revolute">
        <origin xyz="0 0 0" rpy="0 0 0"/>
        <parent link="${prefix}base_link"/>
        <child link="${prefix}link_1"/>
        <axis xyz="0 0 1"/>
        <limit lower="-3.1416" upper="3.1416" effort="0" velocity="2.618"/>
    </joint>
</xacro:macro>
</robot>
"""
