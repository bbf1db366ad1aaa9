"""Robots: the stored row as a `RobotDescription`, and robots and parameter versions as responses."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from models import RobotDescription, iwr
from models._types import Array, Pose6
from models.errors import InvalidInput
from models.structure import description_document, description_from_document
from models.urdf import document_from_urdf
from service.conversions.kinematics import pose6_in, pose6_out
from service.persistence.tables import ParameterVersion, Robot
from service.schemas.common import Pose
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPublic
from service.schemas.structure import StructureDocument


def _pose6(values: Sequence[float]) -> Pose6:
    x, y, z, rx, ry, rz = (float(v) for v in values)
    return (x, y, z, rx, ry, rz)


def description(robot: Robot) -> RobotDescription:
    if robot.structure is None:
        return iwr(_pose6(robot.base), _pose6(robot.tool))
    # Validating and deriving a description costs ~1 ms: the hot paths (kinematics, designs) read it from the
    # app's `ModelCache`, which keeps it per (robot, version); the others (a calibration, a robot's page) pay it.
    return description_from_document(robot.structure, name="custom").with_base_tool(
        _pose6(robot.base), _pose6(robot.tool)
    )


def new_description(body: RobotCreate) -> tuple[RobotDescription, dict[str, Any] | None]:
    """The description a creation request asks for, and the document to store (None for the IWR).

    `base` and `tool` in the body override the document's.
    """
    if body.urdf is not None:
        if body.structure is not None:
            raise InvalidInput("give either structure or urdf, not both", field="urdf")
        for field, value in (("base_link", body.base_link), ("tip_link", body.tip_link)):
            if value is None:
                raise InvalidInput(f"a URDF needs {field}", field=field)
        assert body.base_link is not None and body.tip_link is not None
        document: dict[str, Any] | None = document_from_urdf(body.urdf, body.base_link, body.tip_link)
    elif body.structure is not None:
        document = body.structure.model_dump()  # the JSON shape models.structure reads (absent keys left out)
    elif body.model == "custom":
        raise InvalidInput("a custom robot needs a structure or a urdf", field="structure")
    else:
        return iwr(frame_in(body.base, "base"), frame_in(body.tool, "tool")), None
    desc = description_from_document(document, name="custom")
    base = frame_in(body.base, "base") if body.base is not None else desc.base
    tool = frame_in(body.tool, "tool") if body.tool is not None else desc.tool
    desc = desc.with_base_tool(base, tool)
    return desc, description_document(desc)


def frame_in(pose: Pose | None, what: str) -> Pose6:
    return pose6_in(pose.position, pose.orientation, what) if pose is not None else pose6_in(None, None, what)


def structure_out(desc: RobotDescription, params: Array | None = None) -> StructureDocument:
    """The robots.md document of `desc` with the values of `params` (default nominal), typed."""
    return StructureDocument.model_validate(description_document(desc, params))


def robot_out(robot: Robot) -> RobotPublic:
    desc = description(robot)
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
        structure=structure_out(desc),
        joint_names=list(desc.joint_names),
        joint_units=["mm" if k.boundary_unit == "mm" else "deg" for k in desc.joint_kinds],
        parameter_count=desc.n_params,
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
