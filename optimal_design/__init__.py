"""Optimal pose design: which poses to measure, by convex relaxation with a certificate, rounding and exchange.

Depends on `models` only (the same scaled Jacobian and identifiable subset as the identification).
"""

from optimal_design.criteria import Criterion, metrics
from optimal_design.design import PoseDesign, design_poses
from optimal_design.information import CandidateInformation, candidate_information

__all__ = ["CandidateInformation", "Criterion", "PoseDesign", "candidate_information", "design_poses", "metrics"]
