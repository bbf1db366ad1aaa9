"""Symbolic and numeric kinematics of hybrid serial + hexapod robots (the IWR first).

Pure mathematics: numpy, scipy and CasADi only; nothing here knows about HTTP
or databases. Internal units are millimetres and radians.

Everything built from a robot structure (CasADi Functions, solvers, tables)
lives in a `Runtime`, held by a `Registry`; calls given no `runtime=` use
`default_registry()`.
"""

from models._types import IDENTITY, Array, Pose6, Vec3
from models.campaign import Campaign, make_campaign
from models.description.iwr import iwr
from models.description.parameters import Kind, ParameterScales, ParameterSpec, ParameterTable
from models.description.robot import RobotDescription, Structure
from models.description.terms import Conditions, ModelTerms, make_conditions
from models.engine.runtime import Registry, Runtime, default_registry
from models.errors import (
    CalibrationError,
    InconsistentData,
    InvalidInput,
    InvalidQuaternion,
    JointOutOfRange,
    NonFiniteValue,
    NotIdentifiable,
    SolverFailed,
    TooFewMeasurements,
    UnknownParameter,
    UnreachablePose,
    WrongShape,
)
from models.identifiability import (
    Identifiability,
    analyse_identifiability,
    scaled_jacobian,
    structural_identifiability,
)
from models.kinematics import (
    ForwardJacobianResult,
    ForwardResult,
    forward_kinematics,
    inverse_hexapod,
    solve_platforms,
)
from models.measurement import MeasurementKind
from models.noise import NoiseModel
from models.simulation import SimulatedRobot, measure, perturbed_robot
from models.workspace import sample_workspace

__all__ = [
    "IDENTITY",
    "Array",
    "CalibrationError",
    "Campaign",
    "Conditions",
    "ForwardJacobianResult",
    "ForwardResult",
    "Identifiability",
    "InconsistentData",
    "InvalidInput",
    "InvalidQuaternion",
    "JointOutOfRange",
    "Kind",
    "MeasurementKind",
    "ModelTerms",
    "NoiseModel",
    "NonFiniteValue",
    "NotIdentifiable",
    "ParameterScales",
    "ParameterSpec",
    "ParameterTable",
    "Pose6",
    "Registry",
    "RobotDescription",
    "Runtime",
    "SimulatedRobot",
    "SolverFailed",
    "Structure",
    "TooFewMeasurements",
    "UnknownParameter",
    "UnreachablePose",
    "Vec3",
    "WrongShape",
    "analyse_identifiability",
    "default_registry",
    "forward_kinematics",
    "inverse_hexapod",
    "iwr",
    "make_campaign",
    "make_conditions",
    "measure",
    "perturbed_robot",
    "sample_workspace",
    "scaled_jacobian",
    "solve_platforms",
    "structural_identifiability",
]
