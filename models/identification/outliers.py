"""Poses whose standardised residuals no clean measurement would show (Bonferroni χ² test)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.identification.options import IdentificationOptions
from models.identification.residuals import CampaignProblem
from models.identification.result import Outlier
from models.identification.statistics import PoseErrors, outlier_threshold


def find_outliers(
    problem: CampaignProblem, z: Array, options: IdentificationOptions, *, exclude: bool
) -> tuple[tuple[Outlier, ...], NDArray[np.intp]]:
    """The flagged poses at z, worst first, and those to exclude (all flagged ones when `exclude`)."""
    ev = problem.evaluate(z)
    if ev is None:
        return (), np.empty(0, dtype=np.intp)
    active = problem.active_poses
    stat = np.sum(ev.residuals**2, axis=1)
    threshold = outlier_threshold(active.size, problem.rows, options.outlier_alpha)
    flagged = np.flatnonzero(stat > threshold)
    flagged = flagged[np.argsort(-stat[flagged], kind="stable")]
    errors = PoseErrors.from_raw(ev.residuals / problem.weights[active])
    found = tuple(
        Outlier.at(errors, int(k), pose=int(active[k]), statistic=stat[k], threshold=threshold, excluded=exclude)
        for k in flagged
    )
    return found, (active[flagged] if exclude else np.empty(0, dtype=np.intp))
