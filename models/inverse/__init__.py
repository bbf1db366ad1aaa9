"""Inverse kinematics: joint commands that put a robot's TCP on target (NLP + batched KKT Newton).

`models.compensation` uses it on the calibrated model; the service's kinematics routes on any model.
"""

from models.inverse.report import IkSolution
from models.inverse.solve import inverse_kinematics
from models.inverse.targets import default_seed

__all__ = ["IkSolution", "default_seed", "inverse_kinematics"]
