"""Robots: the stored row as a `RobotDescription`, and robots and parameter versions as responses."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from models import RobotDescription, iwr
from models._types import Array, Pose6
from models.description.structure import description_document, description_from_document
from models.errors import InvalidInput
from models.formats.joint_chain import pose_matrix
from models.formats.ur_kinematics import BASE_LINK as UR_BASE_LINK
from models.formats.ur_kinematics import TIP_LINK as UR_TIP_LINK
from models.formats.ur_kinematics import read_kinematics, urdf_of_kinematics
from models.formats.urdf import UrdfSource, document_from_urdf, refuse_xacro
from models.transforms import matrix_to_rotvec_np
from service.compute.builds import BuildStatus
from service.conversions.kinematics import pose6_in, pose6_out
from service.persistence.tables import ParameterVersion, Robot
from service.schemas.common import Pose
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPublic, StructureBuildPublic
from service.schemas.structure import StructureDocument


def _pose6(values: Sequence[float]) -> Pose6:
    x, y, z, rx, ry, rz = (float(v) for v in values)
    return (x, y, z, rx, ry, rz)


def pose6(values: Sequence[float]) -> Pose6:
    """A stored base or tool (six numbers, internal units) as the description takes it."""
    return _pose6(values)


def description(robot: Robot) -> RobotDescription:
    if robot.structure is None:
        return iwr(_pose6(robot.base), _pose6(robot.tool))
    # Validating and deriving a description costs ~1 ms: the hot paths (kinematics, designs) read it from the
    # app's `ModelCache`, which keeps it per (robot, version); the others (a calibration, a robot's page) pay it.
    return description_from_document(robot.structure, name="custom").with_base_tool(
        _pose6(robot.base), _pose6(robot.tool)
    )


@dataclass(frozen=True)
class NewRobot:
    desc: RobotDescription
    document: dict[str, Any] | None
    """The document to store (None for the IWR)."""
    urdf: UrdfSource | None
    """The URDF to keep, for a robot imported from one (or from UR's kinematics file, through the URDF it makes)."""


def _urdf_source(body: RobotCreate) -> UrdfSource | None:
    sources = (("structure", body.structure), ("urdf", body.urdf), ("import", body.import_))
    given = [field for field, value in sources if value is not None]
    if len(given) > 1:
        raise InvalidInput(f"give one of structure, urdf and import, not {' and '.join(given)}", field=given[1])
    if body.import_ is not None:
        for field, value in (("base_link", body.base_link), ("tip_link", body.tip_link)):
            if value is not None:
                raise InvalidInput(f"an import names its own chain: leave out {field}", field=field)
        # UR's file is the joint origins ur_description turns into a URDF: the robot is that URDF's chain.
        origins = read_kinematics(body.import_.document, field="import.document")
        return UrdfSource(urdf_of_kinematics(origins, name=body.name), UR_BASE_LINK, UR_TIP_LINK)
    if body.urdf is None:
        return None
    refuse_xacro(body.urdf)  # before "a URDF needs base_link": a xacro's links are inside its macros
    for field, value in (("base_link", body.base_link), ("tip_link", body.tip_link)):
        if value is None:
            raise InvalidInput(f"a URDF needs {field}", field=field)
    assert body.base_link is not None and body.tip_link is not None
    return UrdfSource(body.urdf, body.base_link, body.tip_link)


def _compose(a: Pose6, b: Pose6) -> Pose6:
    t = pose_matrix(np.asarray(a, dtype=float)) @ pose_matrix(np.asarray(b, dtype=float))
    return _pose6([*t[:3, 3], *matrix_to_rotvec_np(t[:3, :3])])


def around_urdf(urdf_chain: RobotDescription, base: Pose6 | None, tool: Pose6 | None) -> tuple[Pose6 | None, ...]:
    """world <- base_link and tip_link -> TCP given for a URDF robot as its base and tool: composed with the
    URDF's own frames, the base and tool of `urdf_chain` (the chain as imported)."""
    return (
        _compose(base, urdf_chain.base) if base is not None else None,
        _compose(urdf_chain.tool, tool) if tool is not None else None,
    )


def urdf_source(robot: Robot) -> UrdfSource | None:
    """The URDF a robot was imported from, if it was kept."""
    if robot.urdf is None or robot.base_link is None or robot.tip_link is None:
        return None
    return UrdfSource(robot.urdf, robot.base_link, robot.tip_link)


def new_description(body: RobotCreate) -> NewRobot:
    """The description a creation request asks for, the document to store and the URDF to keep.

    A structure's `base` and `tool` are replaced by the body's. A URDF's are its own frames (base_link <- first
    joint, last joint -> tip_link): the body's compose with them, world <- base_link before and tip_link -> TCP
    after (replacing them dropped the URDF's tip offset: a UR5's TCP 82 mm short).
    """
    source = _urdf_source(body)
    if source is not None:
        document: dict[str, Any] = document_from_urdf(source.urdf, source.base_link, source.tip_link)
    elif body.structure is not None:
        document = body.structure.model_dump()  # the JSON shape models.description.structure reads (absent keys left
        # out)
    elif body.model == "custom":
        raise InvalidInput("a custom robot needs a structure, a urdf or an import", field="structure")
    else:
        return NewRobot(iwr(frame_in(body.base, "base"), frame_in(body.tool, "tool")), None, None)
    desc = description_from_document(document, name="custom")
    base = frame_in(body.base, "base") if body.base is not None else None
    tool = frame_in(body.tool, "tool") if body.tool is not None else None
    if source is not None:
        base, tool = around_urdf(desc, base, tool)
    desc = desc.with_base_tool(base, tool)
    return NewRobot(desc, description_document(desc), source)


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


def build_out(status: BuildStatus) -> StructureBuildPublic:
    return StructureBuildPublic(
        state=status.state.value,
        started_at=status.started_at,
        seconds=status.seconds,
        native=status.native,
        detail=status.detail,
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
