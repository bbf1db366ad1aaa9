"""The calibrated robot as its controller reads it: `GET …/parameters?format=dh | ur-calibration | urdf`.

Each export says which frame it starts from and what it leaves out. The service's world frame is the frame the
calibration's measurements were given in (a tracker's, for a tracker campaign); the calibrated base maps the
robot's base frame into it, and the tool is the TCP the measurements saw. A controller keeps its arm apart from
both, so the exports hold the arm from its own base frame, and state, in a header, world <- that frame and the
TCP on the export's last frame: a reader composes them to get the service's forward kinematics (docs/exports.md).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from models import RobotDescription
from models._types import Array
from models.formats.dh_table import LINK_TRANSFORMS, dh_table, geometric_only
from models.formats.joint_chain import joint_chain, serial_only
from models.formats.ur_kinematics import BASE_LINK as UR_BASE_LINK
from models.formats.ur_kinematics import UrChain, kinematics_yaml, require_6r, ur_chain
from models.formats.urdf import UrdfSource, urdf_from_description
from models.formats.urdf_calibrated import calibrate_urdf, frame_text, splice_origins
from service.conversions.robots import description, urdf_source
from service.conversions.terms import stored_model
from service.persistence import Database, Repository
from service.schemas.exports import ROTATION, DhTablePublic

WORLD = "world: the frame the calibration's measurements were given in (the tracker's, for a tracker campaign)"
DH_MEDIA_TYPE = "application/vnd.iwr.dh-table+json"
"""JSON of its own schema (DhTablePublic): a type of its own, so that application/json stays the parameters'."""
FRAME_KEYS = "[x y z mm, roll pitch yaw deg, R = Rz(yaw)·Ry(pitch)·Rx(roll)]"


@dataclass(frozen=True)
class Export:
    content: str
    media_type: str


@dataclass(frozen=True)
class _Stored:
    """What an export reads of a robot and one of its versions, read in one transaction."""

    robot_id: str
    name: str
    version: int
    provenance: str
    desc: RobotDescription
    values: Array
    urdf: UrdfSource | None

    @property
    def title(self) -> str:
        return f"robot {self.name!r} (id {self.robot_id}), parameter version {self.version} ({self.provenance})"


def _stored(db: Database, robot_id: str, version: int | None) -> _Stored:
    with db.reader() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id)
        row = repo.version(robot_id, version)
        values = np.asarray(row.values, dtype=float)
        desc = stored_model(description(robot), values.size)
        return _Stored(robot.id, robot.name, row.version, row.provenance, desc, values, urdf_source(robot))


def export(*, db: Database, robot_id: str, version: int | None, format: str) -> Export:
    """One of the controller formats; InvalidInput (a 422, field `format`, with the reason) for a robot or a
    version the format cannot hold exactly."""
    stored = _stored(db, robot_id, version)
    if format == "dh":
        return Export(_dh(stored).model_dump_json(), DH_MEDIA_TYPE)
    if format == "ur-calibration":
        return Export(_ur(stored), "application/yaml")
    return Export(_urdf(stored), "application/xml")


def _dh(stored: _Stored) -> DhTablePublic:
    table = dh_table(stored.desc, stored.values)
    return DhTablePublic.model_validate(
        {
            "robot_id": stored.robot_id,
            "version": stored.version,
            "frame": f"base maps the robot's base frame {{0}} into the {WORLD}; the links start at {{0}}",
            "pose": "world <- TCP = base · A_1(q) ⋯ A_n(q) · tool",
            "link_transforms": LINK_TRANSFORMS,
            "rotation": ROTATION,
            "base": asdict(table.base),
            "links": [asdict(row) for row in table.links],
            "tool": asdict(table.tool),
        }
    )


def _ur(stored: _Stored) -> str:
    serial_only(stored.desc, "UR's kinematics file")
    geometric_only(stored.desc, "UR's kinematics file")
    require_6r(tuple(link.joint for link in stored.desc.links))
    geometry = stored.values[: stored.desc.geometric.n_params]
    if stored.urdf is not None:
        u = stored.urdf
        chain = calibrate_urdf(u.urdf, u.base_link, u.tip_link, stored.desc, geometry).ur_chain()
        controller = " (the controller's base)" if u.base_link == UR_BASE_LINK else ""
        root = f"the URDF's base_link {u.base_link!r}{controller}"
    else:
        chain = ur_chain(joint_chain(stored.desc, geometry, what="UR's kinematics file"))
        root = "the robot's base frame {0} of the calibrated model"
    return kinematics_yaml(chain.origins, _ur_header(stored, chain, root))


def _ur_header(stored: _Stored, chain: UrChain, root: str) -> list[str]:
    return [
        f"Kinematics of {stored.title}, for ur_description's kinematics_parameters_file.",
        "Joint origins in metres and radians, roll pitch yaw as URDF's (fixed axes: R = Rz(yaw)·Ry(pitch)·Rx(roll));",
        "each joint turns about its own z.",
        f"Frame: the chain starts at {root}; ur_description hangs it from base_link_inertia.",
        f"{WORLD}.",
        f"world_from_root {FRAME_KEYS}: {frame_text(chain.world_from_root)}",
        f"tip_to_tcp {FRAME_KEYS}: {frame_text(chain.tail)}",
        "(tip: wrist_3_link, which is tool0; the TCP is the one the calibration measured: a controller's TCP setting.)",
        "hash: this file's own; the driver warns that it differs from the controller's checksum, which is right:",
        "the controller keeps its own kinematics.",
    ]


def _urdf(stored: _Stored) -> str:
    serial_only(stored.desc, "a URDF")
    geometric_only(stored.desc, "a URDF")
    geometry = stored.values[: stored.desc.geometric.n_params]
    if stored.urdf is None:
        return urdf_from_description(stored.desc, geometry, name="robot")
    u = stored.urdf
    calibrated = calibrate_urdf(u.urdf, u.base_link, u.tip_link, stored.desc, geometry)
    comment = "\n".join(
        [
            f"Calibrated by the calibration service: {stored.title}.",
            f"Only the origins of the moving joints from {u.base_link!r} to {u.tip_link!r} differ from the imported",
            "document. Frame: the chain starts at base_link as imported.",
            f"{WORLD}.",
            f"world_from_root {FRAME_KEYS}: {frame_text(calibrated.world_from_base_link)}",
            f"tip_to_tcp {FRAME_KEYS}: {frame_text(calibrated.tip_to_tcp)}",
            f"(root: {u.base_link!r}; tip: {u.tip_link!r}; the TCP is the one the calibration measured.)",
        ]
    )
    return splice_origins(u.urdf, calibrated.origins, comment)
