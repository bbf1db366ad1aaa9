"""Identification: measured poses → the robot's real parameters, by IPOPT through CasADi."""

from models.identifiability import minimum_poses, structural_identifiability
from models.identification.accuracy import predicted_accuracy
from models.identification.options import IdentificationOptions, RobustLoss
from models.identification.pipeline import identify
from models.identification.prior import ParameterPrior
from models.identification.registration import RigidFit, registered_base, rigid_fit
from models.identification.result import (
    IdentificationResult,
    Outlier,
    PredictedAccuracy,
    ResidualSummary,
    SolverReport,
    Status,
)
from models.identification.validation import ValidationReport, validate

__all__ = [
    "IdentificationOptions",
    "IdentificationResult",
    "Outlier",
    "ParameterPrior",
    "PredictedAccuracy",
    "ResidualSummary",
    "RigidFit",
    "RobustLoss",
    "SolverReport",
    "Status",
    "ValidationReport",
    "identify",
    "minimum_poses",
    "predicted_accuracy",
    "registered_base",
    "rigid_fit",
    "structural_identifiability",
    "validate",
]
