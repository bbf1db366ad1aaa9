"""Cells of several chains: a robot as a tree of branches (`RobotTree`), its tools' kinematics absolute and
relative, identification over the whole tree, and URDF trees (docs/models.md, "Cells of several chains")."""

from models.tree.accuracy import (
    ToolAccuracy,
    accuracy_profiles,
    predicted_accuracy,
    relative_changes,
    tree_accuracy,
    tree_joint_samples,
)
from models.tree.compensation import RelativeCompensation, compensate_relative, compensate_world
from models.tree.export import UrdfTreeCalibration, branch_dh_tables, calibrate_urdf_tree
from models.tree.identification import TreeFit, identify_tree, restated_fit
from models.tree.kinematics import TreePoses, relative_of, relative_poses, tool_poses, tree_joints
from models.tree.mount import MountStage
from models.tree.records import ToolRecords
from models.tree.simulation import SimulatedTree, measure_tree, perturbed_tree
from models.tree.tree import Branch, RobotTree, TipMap
from models.tree.urdf import tree_from_urdf

__all__ = [
    "Branch",
    "MountStage",
    "RelativeCompensation",
    "RobotTree",
    "SimulatedTree",
    "TipMap",
    "ToolAccuracy",
    "ToolRecords",
    "TreeFit",
    "TreePoses",
    "UrdfTreeCalibration",
    "accuracy_profiles",
    "branch_dh_tables",
    "calibrate_urdf_tree",
    "compensate_relative",
    "compensate_world",
    "identify_tree",
    "measure_tree",
    "perturbed_tree",
    "predicted_accuracy",
    "relative_changes",
    "relative_of",
    "relative_poses",
    "restated_fit",
    "tool_poses",
    "tree_accuracy",
    "tree_from_urdf",
    "tree_joint_samples",
    "tree_joints",
]
