"""What a reference fit's residuals betray: the slips that no pre-fit check can see because the reference is
unknown until it is fitted.

- A plane touched on two faces under one name (the probe slipped onto a step, two plates at one height named
  alike): the touches that fail their plane lie, among themselves, on another plane. Named with the records,
  the offset and the tilt between the two, so that the user gives them their own name.
"""

from __future__ import annotations

import math

import numpy as np

from models._types import Array
from models.identification.diagnosis import Diagnosis, Finding
from models.identification.reference_fit import ReferenceFit
from models.kinematics import forward_kinematics
from models.measurements.references import Plane
from models.robot import RobotDescription
from models.runtime import Runtime

FAILING_SIGMA = 5.0
"""A touch fails its plane beyond this many σ (a clean touch does not, a step of a tenth of a mm does)."""
MIN_OTHER_TOUCHES = 4
"""Touches needed before their own plane means anything (three always lie on one)."""
OWN_PLANE_SIGMA = 3.0
"""Touches on one face of their own fit it to within a few σ (RMS)."""


def plane_mixups(
    desc: RobotDescription, fit: ReferenceFit, sigma_mm: float, *, runtime: Runtime
) -> tuple[Diagnosis, ...]:
    """An `OTHER_PLANE` finding per plane whose failing touches lie on a plane of their own."""
    found = []
    for group, estimate in zip(fit.groups, fit.references, strict=True):
        plane = group.reference
        if not isinstance(plane, Plane):
            continue
        normal, _, _ = plane.normal_at(float(estimate.values[0]), float(estimate.values[1]))
        p = forward_kinematics(desc, group.joints, fit.parameters, check_ranges=False, runtime=runtime).positions
        sigma = np.full(group.size, sigma_mm) if group.sigma_mm is None else np.asarray(group.sigma_mm)
        signed = p @ normal - float(estimate.values[2])
        failing = np.flatnonzero(np.abs(signed) > FAILING_SIGMA * sigma)
        if failing.size < MIN_OTHER_TOUCHES:
            continue
        other, misfit = _best_plane(p[failing])
        if misfit > OWN_PLANE_SIGMA * float(np.median(sigma[failing])):
            continue
        tilt = math.degrees(math.acos(min(1.0, abs(float(other @ normal)))))
        records = tuple(int(i) for i in group.positions[failing])
        found.append(
            Diagnosis(
                Finding.OTHER_PLANE,
                f"{failing.size} touches of plane {plane.name!r} (records {list(records[:10])}) lie on another plane "
                f"{float(np.mean(signed[failing])):+.3g} mm from it and tilted {tilt:.2g}° (they fit it to "
                f"{misfit * 1000:.2g} µm RMS): another face was touched under this name; give those touches their "
                "own plane",
                records,
                blocking=False,
            )
        )
    return tuple(found)


def _best_plane(points: Array) -> tuple[Array, float]:
    """The plane through `points` (least squares): its unit normal and the RMS distance of the points from it."""
    centred = points - points.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    return vt[-1], float(s[-1] / math.sqrt(points.shape[0]))
