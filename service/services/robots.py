from __future__ import annotations

from typing import Any

import numpy as np

from models.structure import description_document
from models.urdf import urdf_from_description
from service.conversions.robots import description, new_description, parameters_out, robot_out
from service.persistence import Database, Repository
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPublic


def create_robot(*, db: Database, body: RobotCreate) -> RobotPublic:
    desc, document = new_description(body)  # InvalidInput (a 422 naming the field) for a bad document
    nominal = desc.parameters.nominal.tolist()
    model = "iwr" if document is None else "custom"
    with db.session() as s:
        repo = Repository(s)
        return robot_out(
            repo.add_robot(body.name, model, list(desc.base), list(desc.tool), nominal, structure=document)
        )


def list_robots(*, db: Database, limit: int, offset: int) -> list[RobotPublic]:
    with db.reader() as s:
        return [robot_out(r) for r in Repository(s).robots(limit, offset)]


def get_robot(*, db: Database, robot_id: str) -> RobotPublic:
    with db.reader() as s:
        return robot_out(Repository(s).robot(robot_id))


def delete_robot(*, db: Database, robot_id: str) -> None:
    with db.session() as s:
        Repository(s).delete_robot(robot_id)


def get_parameters(*, db: Database, robot_id: str, version: int | None) -> ParametersPublic:
    with db.reader() as s:
        repo = Repository(s)
        return parameters_out(description(repo.robot(robot_id)), repo.version(robot_id, version))


def get_parameters_urdf(*, db: Database, robot_id: str, version: int | None) -> str:
    """The URDF of a serial robot with the values of a parameter version (InvalidInput for a hexapod)."""
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
    return urdf_from_description(desc, values, name="robot")


def get_structure(*, db: Database, robot_id: str, version: int | None) -> dict[str, Any]:
    """The robot's description document with the values of a parameter version (POST /v1/robots takes it)."""
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
    return description_document(desc, values)
