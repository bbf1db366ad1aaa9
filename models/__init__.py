"""Symbolic and numeric kinematics of hybrid serial + hexapod robots (the IWR first).

Pure mathematics: numpy, scipy and CasADi only; nothing here knows about HTTP
or databases. Internal units are millimetres and radians.
"""

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
from models.function_cache import FUNCTIONS, RobotFunctions, functions_for
from models.hybrid import RobotDescription, Tolerances
from models.identifiability import (
    Identifiability,
    NoiseModel,
    analyse_identifiability,
    scaled_jacobian,
)
from models.iwr import iwr
from models.kinematics import ForwardResult, forward_kinematics, inverse_hexapod, solve_platforms
from models.parameters import Kind, ParameterSpec, ParameterTable
from models.workspace import sample_workspace

__all__ = [
    "FUNCTIONS",
    "CalibrationError",
    "ForwardResult",
    "Identifiability",
    "InconsistentData",
    "InvalidInput",
    "InvalidQuaternion",
    "JointOutOfRange",
    "Kind",
    "NoiseModel",
    "NonFiniteValue",
    "NotIdentifiable",
    "ParameterSpec",
    "ParameterTable",
    "RobotDescription",
    "RobotFunctions",
    "SolverFailed",
    "Tolerances",
    "TooFewMeasurements",
    "UnknownParameter",
    "UnreachablePose",
    "WrongShape",
    "analyse_identifiability",
    "forward_kinematics",
    "functions_for",
    "inverse_hexapod",
    "iwr",
    "sample_workspace",
    "scaled_jacobian",
    "solve_platforms",
]
