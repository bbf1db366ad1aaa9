"""The cell around a robot: its links' collision geometry, the fixed obstacles, the instruments, and which
candidate poses it can measure (`check_poses`), each refusal with its reason."""

from models.cell.cell import Cell, Obstacle, Pair, pair
from models.cell.feasibility import Feasibility, Reason, cell_for, check_poses, default_allowed
from models.cell.frames import FrameLayout, frame_layout, stage_frames
from models.cell.geometry import Attached, RobotGeometry, Segment, default_geometry
from models.cell.instruments import Ballbar, Camera, Target, Tracker
from models.cell.shapes import Box, Capsule, Cylinder, Mesh, Shape, Sphere
from models.cell.urdf_shapes import urdf_geometry

__all__ = [
    "Attached",
    "Ballbar",
    "Box",
    "Camera",
    "Capsule",
    "Cell",
    "Cylinder",
    "Feasibility",
    "FrameLayout",
    "Mesh",
    "Obstacle",
    "Pair",
    "Reason",
    "RobotGeometry",
    "Segment",
    "Shape",
    "Sphere",
    "Target",
    "Tracker",
    "cell_for",
    "check_poses",
    "default_allowed",
    "default_geometry",
    "frame_layout",
    "pair",
    "stage_frames",
    "urdf_geometry",
]
