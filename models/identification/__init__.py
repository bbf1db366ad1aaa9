"""Identification: measured poses → the robot's real parameters, by IPOPT through CasADi."""

from models.identification.identify import identify, minimum_poses, predicted_accuracy
from models.identification.options import IdentificationOptions, RobustLoss
from models.identification.registration import RigidFit, registered_base, rigid_fit
from models.identification.result import IdentificationResult, Outlier, PredictedAccuracy, ResidualSummary, SolverReport
from models.identification.validation import ValidationReport, validate

__all__ = [
    "IdentificationOptions",
    "IdentificationResult",
    "Outlier",
    "PredictedAccuracy",
    "ResidualSummary",
    "RigidFit",
    "RobustLoss",
    "SolverReport",
    "ValidationReport",
    "identify",
    "minimum_poses",
    "predicted_accuracy",
    "registered_base",
    "rigid_fit",
    "validate",
]
