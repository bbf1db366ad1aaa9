"""Robots: the stored row as a `RobotDescription`, and robots and parameter versions as responses."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from models import RobotDescription, iwr
from models._types import Pose6
from service.conversions.kinematics import pose6_in, pose6_out
from service.persistence.tables import ParameterVersion, Robot
from service.schemas.common import Pose
from service.schemas.robots import ParametersPublic, RobotPublic


def _pose6(values: Sequence[float]) -> Pose6:
    x, y, z, rx, ry, rz = (float(v) for v in values)
    return (x, y, z, rx, ry, rz)


def description(robot: Robot) -> RobotDescription:
    return iwr(_pose6(robot.base), _pose6(robot.tool))


def frame_in(pose: Pose | None, what: str) -> Pose6:
    return pose6_in(pose.position, pose.orientation, what) if pose is not None else pose6_in(None, None, what)


def robot_out(robot: Robot) -> RobotPublic:
    return RobotPublic(
        id=robot.id,
        name=robot.name,
        model=robot.model,
        parameter_version=robot.current_version,
        created_at=robot.created_at,
        base=pose6_out(robot.base),
        tool=pose6_out(robot.tool),
        notes=robot.notes,
        revision=robot.revision or 1,
    )


def parameters_out(desc: RobotDescription, version: ParameterVersion) -> ParametersPublic:
    table = desc.parameters
    values = table.as_boundary(np.asarray(version.values, dtype=float)).tolist()
    nominal = table.as_boundary(table.nominal).tolist()
    scale = table.to_boundary.tolist()
    std = version.std_errors or [None] * len(table)
    ident = version.identifiable or [None] * len(table)
    return ParametersPublic.model_validate(
        {
            "version": version.version,
            "provenance": version.provenance,
            "calibration_id": version.calibration_id,
            "parameters": [
                {
                    "name": name,
                    "value": values[i],
                    "unit": table.units[i],
                    "nominal": nominal[i],
                    "std_error": None if std[i] is None else float(std[i]) * scale[i],
                    "identifiable": ident[i],
                }
                for i, name in enumerate(table.names)
            ],
        }
    )
