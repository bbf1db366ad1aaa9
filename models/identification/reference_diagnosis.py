"""What a reference fit's residuals betray: the slips that no pre-fit check can see because the reference is
unknown until it is fitted. Each kind of reference says what its own records betray (`Reference.misfits`: a
plane touched on two faces under one name); this module asks every group at the fit's solution.
"""

from __future__ import annotations

import numpy as np

from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.identification.diagnosis import Diagnosis, Finding
from models.identification.reference_fit import ReferenceFit
from models.kinematics import forward_kinematics


def reference_misfits(
    desc: RobotDescription, fit: ReferenceFit, sigma_mm: float, *, runtime: Runtime
) -> tuple[Diagnosis, ...]:
    """Every reference's findings at the solution (`Reference.misfits`), none blocking."""
    found = []
    for group, estimate in zip(fit.groups, fit.references, strict=True):
        tcp = forward_kinematics(desc, group.joints, fit.parameters, check_ranges=False, runtime=runtime)
        sigma = np.full(group.size, sigma_mm) if group.sigma_mm is None else np.asarray(group.sigma_mm)
        for misfit in group.reference.misfits(tcp, np.asarray(estimate.values, dtype=float), sigma, group.positions):
            found.append(Diagnosis(Finding(misfit.finding), misfit.message, misfit.records, blocking=False))
    return tuple(found)
