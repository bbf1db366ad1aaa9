from __future__ import annotations

from models import iwr
from service.conversions.robots import description, frame_in, parameters_out, robot_out
from service.persistence import Database, Repository
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPublic


def create_robot(*, db: Database, body: RobotCreate) -> RobotPublic:
    base, tool = frame_in(body.base, "base"), frame_in(body.tool, "tool")
    nominal = iwr(base, tool).parameters.nominal.tolist()
    with db.session() as s:
        return robot_out(Repository(s).add_robot(body.name, body.model, list(base), list(tool), nominal))


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
