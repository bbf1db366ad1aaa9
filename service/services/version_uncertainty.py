"""The current parameter version with its uncertainty, as quick checks and predicted accuracies need it."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from models import RobotDescription
from models._types import Array
from models.evaluation.checks import CALIBRATION_POSES, version_covariance
from service.conversions.robots import description
from service.conversions.terms import stored_model
from service.persistence import Repository


@dataclass(frozen=True)
class VersionUncertainty:
    """The current version: its model, values and parameter covariance (table order, internal units)."""

    desc: RobotDescription
    number: int
    values: Array
    covariance: Array
    calibration_poses: int
    conditions: dict[str, Any] | None = None
    """What the version's campaign was measured under (None: no campaign made it)."""
    calibration_id: str | None = None
    """The calibration that made it (None: nominal, imported, or judged against its tolerances)."""

    @property
    def estimated(self) -> NDArray[np.intp]:
        """Indices of the parameters with an uncertainty (the others are held: covariance 0)."""
        return np.flatnonzero(np.diag(self.covariance) > 0)


def nominal_uncertainty(repo: Repository, robot_id: str) -> VersionUncertainty:
    """The current version with the nominal tolerances (each parameter's expected error) as its uncertainty."""
    desc = description(repo.robot(robot_id))
    row = repo.version(robot_id)
    values = np.asarray(row.values, dtype=float)
    model = stored_model(desc, values.size)
    covariance = np.diag(model.parameters.scales**2)
    return VersionUncertainty(model, row.version, values, covariance, CALIBRATION_POSES, row.conditions)


def calibrated_uncertainty(repo: Repository, robot_id: str) -> VersionUncertainty | None:
    """The current version with its calibration's standard errors and correlations; None where it carries no
    calibrated uncertainty (the nominal or an imported version)."""
    desc = description(repo.robot(robot_id))
    row = repo.version(robot_id)
    values = np.asarray(row.values, dtype=float)
    model = stored_model(desc, values.size)
    table = model.parameters
    stored = list(row.std_errors or [])
    std = np.array([math.nan if v is None else float(v) for v in stored] + [math.nan] * (len(table) - len(stored)))
    if not np.any(np.isfinite(std) & (std > 0)):
        return None
    names, correlation, poses = None, None, CALIBRATION_POSES
    if row.calibration_id is not None:
        document = repo.calibration(row.calibration_id).result
        stored_correlation = document.get("correlation")
        if stored_correlation:
            names, correlation = stored_correlation["names"], np.asarray(stored_correlation["matrix"], dtype=float)
        poses = int(document.get("measurements") or CALIBRATION_POSES)
    covariance = version_covariance(table, std[: len(table)], names, correlation)
    return VersionUncertainty(model, row.version, values, covariance, poses, row.conditions, row.calibration_id)
