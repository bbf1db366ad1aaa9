"""Optimal pose design: which poses to measure, by convex relaxation with a certificate, rounding and exchange.

Depends on `models` only (the same scaled Jacobian and identifiable subset as the identification).
"""

from models.errors import TargetUnreachable
from optimal_design.constraints import KeepOut, spread_distance
from optimal_design.criteria import Criterion, metrics
from optimal_design.design import DesignOptions, PoseDesign, design_poses
from optimal_design.information import CandidateInformation, candidate_information
from optimal_design.target import TargetDesign, design_for_target

__all__ = [
    "CandidateInformation",
    "Criterion",
    "DesignOptions",
    "KeepOut",
    "PoseDesign",
    "TargetDesign",
    "TargetUnreachable",
    "candidate_information",
    "design_for_target",
    "design_poses",
    "metrics",
    "spread_distance",
]
