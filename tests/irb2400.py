"""ROS-Industrial's ABB IRB 2400 as its support package describes it, shared by the tests of URDF joint names
(tests/service) and of the identifiable subset at the fitted geometry (tests/identification)."""

from tests.urdf import X_AXIS, Y_AXIS, Z_AXIS, UrdfJoint, urdf_robot

# ROS-Industrial's ABB IRB 2400 (abb_irb2400_support), its xacro macro expanded: the joint origins, axes and limits
# of that package, link and joint names as it writes them (joint_1 … joint_6, link_1 … link_6, tool0), written
# here without the meshes.
IRB2400_JOINTS = [
    UrdfJoint("joint_1", "revolute", "base_link", "link_1", "0 0 0", Z_AXIS, ("-3.1416", "3.1416", "0", "2.618")),
    UrdfJoint("joint_2", "revolute", "link_1", "link_2", "0.1 0 0.615", Y_AXIS, ("-1.7453", "1.9199", "0", "2.618")),
    UrdfJoint("joint_3", "revolute", "link_2", "link_3", "0 0 0.705", Y_AXIS, ("-1.0472", "1.1345", "0", "2.618")),
    UrdfJoint("joint_4", "revolute", "link_3", "link_4", "0.258 0 0.135", X_AXIS, ("-3.49", "3.49", "0", "6.2832")),
    UrdfJoint("joint_5", "revolute", "link_4", "link_5", "0.497 0 0", Y_AXIS, ("-2.0944", "2.0944", "0", "6.2832")),
    UrdfJoint("joint_6", "revolute", "link_5", "link_6", "0.085 0 0", X_AXIS, ("-6.9813", "6.9813", "0", "7.854")),
    UrdfJoint("joint_6-tool0", "fixed", "link_6", "tool0"),
    UrdfJoint("base_link-base", "fixed", "base_link", "base"),
]
IRB2400_URDF = urdf_robot("abb_irb2400", IRB2400_JOINTS)
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
