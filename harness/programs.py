"""Robot programs written as the vendors' tools write them, from poses, and the nominal controller that runs
them: what the program-compensation tests and benchmark share.

`ur5_cell()` is the subject: the UR5-like arm, a perturbed "true" robot (its parameters are the calibrated
ones: an independent truth) and joint vectors away from the arm's singularities and joint limits."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from models import RobotDescription, forward_kinematics
from models._types import Array
from models.compensation.controller import ControllerFrame, urdf_controller_frame
from models.compensation.poses import matrix_pose6, pose6_matrix, pose_matrices
from models.description.examples import ur5_like
from models.description.structure import description_from_document
from models.engine.runtime import runtime_for
from models.formats.ur_kinematics import BASE_LINK as UR_BASE_LINK
from models.formats.ur_kinematics import TIP_LINK as UR_TIP_LINK
from models.formats.ur_kinematics import read_kinematics, urdf_of_kinematics
from models.formats.urdf import document_from_urdf
from models.inverse.problem import joint_weights
from models.inverse.routing import IkBatch
from models.simulation import perturbed_robot
from programs.frames import matrix_abc, matrix_quaternion, matrix_rotvec

JOINT_BOX_DEG = ((-40, 40), (-120, -60), (50, 110), (-120, -60), (60, 120), (-40, 40))
"""Within 30-40° of HOME_DEG, shoulder, elbow and wrist well inside their branches: the solution nearest the
home joints is the taught one (from 60° away, the straight path from home crosses to another branch for 1
target in 12)."""
HOME_DEG = (0.0, -90.0, 80.0, -90.0, 90.0, 0.0)
"""The box's middle: the joints a program starts from (the request's `seed`)."""
FIXTURE = np.array(
    [[0.866025404, -0.5, 0.0, 400.0], [0.5, 0.866025404, 0.0, -200.0], [0.0, 0.0, 1.0, 50.0], [0, 0, 0, 1]]
)
"""A program's base (KRL BASE_DATA, RAPID wobjdata): 30° about z, 400 mm out, 200 mm aside, 50 mm up."""


@dataclass(frozen=True)
class Cell:
    desc: RobotDescription
    nominal: Array
    truth: Array

    @property
    def tool(self) -> Array:
        """The nominal tool (flange -> TCP) as a program declares it (KRL TOOL_DATA, RAPID tooldata)."""
        return pose6_matrix(self.nominal[self.desc.slices["tool"]])

    @property
    def base(self) -> Array:
        """World <- the robot's base: the calibrated (here the true) model's base frame."""
        return pose6_matrix(self.truth[self.desc.slices["base"]])

    def promised(self, tool: Array | None = None) -> Array:
        """The nominal controller's parameters: the nominal geometry on the calibrated base (and a program's tool)."""
        theta = self.nominal.copy()
        theta[self.desc.slices["base"]] = self.truth[self.desc.slices["base"]]
        return _with_tool(self.desc, theta, tool)


def _with_tool(desc: RobotDescription, theta: Array, tool: Array | None) -> Array:
    out = theta.copy()
    if tool is not None:
        out[desc.slices["tool"]] = matrix_pose6(tool)
    return out


def ur5_cell(seed: int = 3) -> Cell:
    desc = ur5_like()
    sim = perturbed_robot(desc, seed=seed)
    return Cell(desc, sim.nominal, sim.truth)


UR10E_KINEMATICS = """\
kinematics:
  shoulder:
    x: 0
    y: 0
    z: 0.1807
    roll: 0
    pitch: 0
    yaw: 0
  upper_arm:
    x: 0
    y: 0
    z: 0
    roll: 1.570796327
    pitch: 0
    yaw: 0
  forearm:
    x: -0.6127
    y: 0
    z: 0
    roll: 0
    pitch: 0
    yaw: 0
  wrist_1:
    x: -0.57155
    y: 0
    z: 0.17415
    roll: 0
    pitch: 0
    yaw: 0
  wrist_2:
    x: 0
    y: -0.11985
    z: -2.458164590756244e-11
    roll: 1.570796327
    pitch: 0
    yaw: 0
  wrist_3:
    x: 0
    y: 0.11655
    z: -2.390480459346185e-11
    roll: 1.570796326589793
    pitch: 3.141592653589793
    yaw: 3.141592653589793
  hash: calib_12788084448423163542
"""
"""A UR10e's `default_kinematics.yaml` as ur_description ships it (the published dimensions, the file's shape)."""


def ur10e_cell(seed: int = 3) -> tuple[Cell, ControllerFrame]:
    """A UR10e imported from its kinematics file as the service imports it, a perturbed truth as its calibration,
    and the controller frame its programs are in (UR's Base, 180.7 mm below the model's {0})."""
    urdf = urdf_of_kinematics(read_kinematics(UR10E_KINEMATICS))
    desc = description_from_document(document_from_urdf(urdf, UR_BASE_LINK, UR_TIP_LINK))
    sim = perturbed_robot(desc, seed=seed)
    return Cell(desc, sim.nominal, sim.truth), urdf_controller_frame(urdf, UR_BASE_LINK, UR_TIP_LINK, ur_file=True)


def taught_in(cell: Cell, frame: ControllerFrame, q: Array) -> Array:
    """(N, 4, 4) the targets the nominal controller reaches at joints `q`, in its own base frame."""
    return np.asarray(np.linalg.solve(frame.zero_from_controller, taught(cell, q)), dtype=float)


def joints(n: int, seed: int = 0) -> Array:
    rng = np.random.default_rng(seed)
    box = np.radians(np.array(JOINT_BOX_DEG, dtype=float))
    return rng.uniform(box[:, 0], box[:, 1], size=(n, 6))


def taught(cell: Cell, q: Array, *, base: Array | None = None, tool: Array | None = None) -> Array:
    """(N, 4, 4) the targets the nominal controller reaches at joints `q`, in the program's base frame."""
    fk = forward_kinematics(cell.desc, q, cell.promised(tool))
    world = pose_matrices(fk.positions, fk.rotations)
    frame = cell.base @ (np.eye(4) if base is None else base)
    return np.asarray(np.linalg.solve(frame, world), dtype=float)


def executed(
    cell: Cell,
    poses: Array,
    taught_at: Array,
    *,
    base: Array | None = None,
    tool: Array | None = None,
    real: Array | None = None,
) -> Array:
    """Where the true robot's TCP goes (world, (N, 3) mm) when the nominal controller runs to `poses` (the
    program's base frame) in the configuration the program was taught in (`taught_at`, the joints): the nominal
    model's solution from those joints (Newton, as a controller's iterative IK), then the true forward
    kinematics. `real`: the robot that moves, with the tool it physically carries, where the cell's `truth` is
    only a calibration of it (the program's `tool` is then the controller's tool data only)."""
    world = cell.base @ (np.eye(4) if base is None else base) @ poses
    n = world.shape[0]
    target = np.hstack([world[:, :3, 3], world[:, :3, :3].transpose(0, 2, 1).reshape(n, 9)])
    theta = cell.promised(tool)
    batch = IkBatch(cell.desc, theta, target, taught_at, joint_weights(cell.desc, None), False, runtime_for(cell.desc))
    v, converged = batch.newton(taught_at.copy())
    assert batch.accepted(v, converged).all()
    moving = _with_tool(cell.desc, cell.truth, tool) if real is None else real
    return np.asarray(forward_kinematics(cell.desc, v, moving).positions)


def world_positions(cell: Cell, poses: Array, base: Array | None = None) -> Array:
    return np.asarray((cell.base @ (np.eye(4) if base is None else base) @ poses)[:, :3, 3])


# ---------------------------------------------------------------- writers, one per dialect


def _turn(q: Array) -> int:
    return int(sum(1 << k for k in range(6) if q[k] < 0))


def _abc_text(frame: Array) -> str:
    a, b, c = matrix_abc(frame[:3, :3])
    x, y, z = frame[:3, 3]
    return f"X {x:.4f},Y {y:.4f},Z {z:.4f},A {a:.5f},B {b:.5f},C {c:.5f}"


def krl_config(base: Array, tool: Array) -> str:
    """The lines of a $config.dat that hold BASE_DATA[1] and TOOL_DATA[1]."""
    return (
        "DEFDAT  $CONFIG\r\n;FOLD BASISTECH GLOBALS\r\n"
        "DECL GLOBAL FRAME TOOL_DATA[16]\r\nDECL GLOBAL FRAME BASE_DATA[32]\r\n"
        f"TOOL_DATA[1]={{{_abc_text(tool)}}}\r\nBASE_DATA[1]={{{_abc_text(base)}}}\r\n;ENDFOLD\r\nENDDAT\r\n"
    )


def krl_pair(poses: Sequence[Array], q: Array, *, name: str = "weld") -> tuple[str, str]:
    """A .src and its .dat as KUKA's inline forms write them (CRLF, folds, E6POS with S and T, FDAT with tool 1
    and base 1, LDAT)."""
    src = [f"&ACCESS RVP\r\n&REL 1\r\nDEF {name}( )\r\n;FOLD INI\r\n  BAS (#INITMOV,0 )\r\n;ENDFOLD (INI)\r\n"]
    dat = [f"&ACCESS RVP\r\n&REL 1\r\nDEFDAT  {name}\r\n;FOLD EXTERNAL DECLARATIONS;%{{PE}}%V3.2.0\r\n"]
    dat.append(";ENDFOLD (EXTERNAL DECLARATIONS)\r\n")
    for k, (pose, qk) in enumerate(zip(poses, q, strict=True), start=1):
        a, b, c = matrix_abc(pose[:3, :3])
        x, y, z = pose[:3, 3]
        motion = "PTP" if k % 5 == 1 else "LIN"
        src.append(f";FOLD {motion} P{k} CONT Vel=2 m/s CPDAT{k} Tool[1] Base[1];%{{PE}}\r\n")
        src.append(f"$BWDSTART=FALSE\r\nLDAT_ACT=LCPDAT{k}\r\nFDAT_ACT=FP{k}\r\nBAS(#CP_PARAMS,2)\r\n")
        src.append(f"{motion} XP{k} C_DIS\r\n;ENDFOLD\r\n")
        dat.append(
            f"DECL E6POS XP{k}={{X {x:.7g},Y {y:.7g},Z {z:.7g},A {a:.7g},B {b:.7g},C {c:.7g},S 2,T {_turn(qk)},"
            "E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}\r\n"
        )
        dat.append(f'DECL FDAT FP{k}={{TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}}\r\n')
        dat.append(f"DECL LDAT LCPDAT{k}={{VEL 2.0,ACC 100.0,APO_DIST 100.0,APO_FAC 50.0,ORI_TYP #VAR}}\r\n")
    src.append("END\r\n")
    dat.append("ENDDAT\r\n")
    return "".join(src), "".join(dat)


def rapid_pose(frame: Array, decimals: int = 4) -> str:
    """A pose's RAPID literal: [[x, y, z] mm with `decimals` places], [qw, qx, qy, qz]]."""
    x, y, z = frame[:3, 3]
    w, qx, qy, qz = matrix_quaternion(frame[:3, :3])
    return f"[[{x:.{decimals}f},{y:.{decimals}f},{z:.{decimals}f}],[{w:.9f},{qx:.9f},{qy:.9f},{qz:.9f}]]"


def rapid_robtarget(pose: Array, q: Array, decimals: int = 4) -> str:
    """A robtarget's literal: the pose, the confdata of the joints `q` it was taught at (the quarter turns of
    axes 1, 4 and 6), no external axes."""
    cf = [int(np.floor(q[j] / (np.pi / 2))) for j in (0, 3, 5)]
    return f"{rapid_pose(pose, decimals)[:-1]},[{cf[0]},{cf[1]},{cf[2]},0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"


def rapid_cell_module(cell: Cell, *data: str) -> str:
    """The cell's system module as a controller keeps one: the probe's tooldata tProbe and the fixture's wobjdata
    wFixture, then the `data` lines."""
    return (
        "MODULE CellData(SYSMODULE)\r\n"
        f"  PERS tooldata tProbe:=[TRUE,{rapid_pose(cell.tool)},[0.5,[0,0,50],[1,0,0,0],0,0,0]];\r\n"
        f'  TASK PERS wobjdata wFixture:=[FALSE,TRUE,"",{rapid_pose(FIXTURE)},[[0,0,0],[1,0,0,0]]];\r\n'
        + "".join(data)
        + "ENDMODULE\r\n"
    )


def flexpendant_header(module: str) -> str:
    """A module's first lines as the FlexPendant saves it (CRLF): the `%%%` header, then MODULE `module`."""
    return f"%%%\r\n  VERSION:1\r\n  LANGUAGE:ENGLISH\r\n%%%\r\n\r\nMODULE {module}\r\n"


@dataclass(frozen=True)
class ProbeTargets:
    """The targets the nominal controller reaches at joints `q` (one a row), taught with the probe's tooldata
    tProbe, each in the fixture's wobjdata wFixture or where `in_fixture` says not, in wobj0 (the robot's base):
    as the RAPID tests write them into their modules (`rapid_cell_module` declares both frames)."""

    cell: Cell
    q: Array
    in_fixture: Sequence[bool]

    def pose(self, k: int) -> Array:
        base = FIXTURE if self.in_fixture[k] else None
        return np.asarray(taught(self.cell, self.q[k : k + 1], base=base, tool=self.cell.tool)[0])

    def robtarget(self, k: int) -> str:
        return rapid_robtarget(self.pose(k), self.q[k])

    def misses(self, k: int, compensated: Array) -> tuple[float, float]:
        """How far (mm) the true robot's TCP lands from target `k` when the nominal controller runs to it from the
        joints it was taught at: to `compensated` (its pose as the rewritten program reads), then as taught."""
        base = FIXTURE if self.in_fixture[k] else None
        wanted = world_positions(self.cell, self.pose(k)[None], base=base)
        run = executed(self.cell, compensated[None], self.q[k : k + 1], base=base, tool=self.cell.tool)
        before = executed(self.cell, self.pose(k)[None], self.q[k : k + 1], base=base, tool=self.cell.tool)
        return float(np.linalg.norm(run - wanted)), float(np.linalg.norm(before - wanted))


def rapid_module(poses: Sequence[Array], q: Array, *, base: Array, tool: Array) -> str:
    """A module as RobotStudio writes one: a tooldata and a wobjdata, CONST robtargets, MoveJ then MoveL."""
    lines = [
        "MODULE Module1\r\n",
        f"    PERS tooldata tProbe:=[TRUE,{rapid_pose(tool)},[0.5,[0,0,50],[1,0,0,0],0,0,0]];\r\n",
        f'    TASK PERS wobjdata wFixture:=[FALSE,TRUE,"",{rapid_pose(base)},[[0,0,0],[1,0,0,0]]];\r\n',
    ]
    for k, (pose, qk) in enumerate(zip(poses, q, strict=True), start=1):
        lines.append(f"    CONST robtarget Target_{k * 10}:={rapid_robtarget(pose, qk, decimals=6)};\r\n")
    lines.append("    PROC Path_10()\r\n")
    for k in range(1, len(poses) + 1):
        move = "MoveJ" if k == 1 else "MoveL"
        lines.append(f"        {move} Target_{k * 10},v1000,z100,tProbe\\WObj:=wFixture;\r\n")
    lines.append("    ENDPROC\r\nENDMODULE\r\n")
    return "".join(lines)


def krl_in_fixture(cell: Cell, q: Array, tool: Array | None = None) -> tuple[str, str]:
    """`krl_pair` of the targets the nominal controller reaches at joints `q`, taught in the fixture with `tool`
    (default the cell's): the frames `krl_config(FIXTURE, tool)` declares as BASE_DATA[1] and TOOL_DATA[1]."""
    tool = cell.tool if tool is None else tool
    return krl_pair(list(taught(cell, q, base=FIXTURE, tool=tool)), q)


def rapid_in_fixture(cell: Cell, q: Array, tool: Array | None = None) -> str:
    """`rapid_module` of the targets the nominal controller reaches at joints `q`, taught in the fixture's
    wobjdata with `tool` (default the cell's) as its tooldata."""
    tool = cell.tool if tool is None else tool
    return rapid_module(list(taught(cell, q, base=FIXTURE, tool=tool)), q, base=FIXTURE, tool=tool)


def urscript_program(poses: Sequence[Array]) -> str:
    """A script as Polyscope exports one: waypoints as global variables, movej to the first, movel after."""
    lines = ["def program():\n", "  # waypoints\n"]
    for k, pose in enumerate(poses, start=1):
        x, y, z = pose[:3, 3] / 1e3
        rx, ry, rz = matrix_rotvec(pose[:3, :3])
        lines.append(f"  global Waypoint_{k}_p=p[{x:.9f}, {y:.9f}, {z:.9f}, {rx:.9f}, {ry:.9f}, {rz:.9f}]\n")
    for k in range(1, len(poses) + 1):
        move = "movej" if k == 1 else "movel"
        lines.append(f"  {move}(Waypoint_{k}_p, a=1.2, v=0.25)\n")
    lines.append("end\n")
    return "".join(lines)


def urscript_approached(poses: Sequence[Array], approach: Array) -> str:
    """A script of linear moves to pose literals, each after a joint move (radians) to `approach[k]`: the
    program fixes each target's branch itself (UR's controller starts from the joints of the previous move)."""
    lines = ["def weld():\n"]
    for pose, near in zip(poses, approach, strict=True):
        x, y, z = pose[:3, 3] / 1e3
        rx, ry, rz = matrix_rotvec(pose[:3, :3])
        lines.append(f"  movej([{', '.join(f'{v:.6f}' for v in near)}], a=1.4, v=1.05)\n")
        lines.append(f"  movel(p[{x:.9f}, {y:.9f}, {z:.9f}, {rx:.9f}, {ry:.9f}, {rz:.9f}], a=1.2, v=0.25)\n")
    return "".join([*lines, "end\n"])


def csv_table(poses: Sequence[Array]) -> str:
    rows = ["name,x,y,z,qw,qx,qy,qz\r\n"]
    for k, pose in enumerate(poses, start=1):
        x, y, z = pose[:3, 3]
        w, qx, qy, qz = matrix_quaternion(pose[:3, :3])
        rows.append(f"P{k},{x:.5f},{y:.5f},{z:.5f},{w:.8f},{qx:.8f},{qy:.8f},{qz:.8f}\r\n")
    return "".join(rows)
