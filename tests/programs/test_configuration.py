"""The configuration the controller will take: the program's own joint moves and declared configurations.

Issue 44: 25 targets of mixed configurations with no seed came back 1.52 mm off (worse than uncompensated),
silently, and ConfL \\Off was ignored. Here the UR5-like cell's targets are taught on two wrist branches; each
is preceded by a joint move near its own joints, as a program moves the arm before a linear approach. The
compensated targets, run by the nominal controller from the joints the robot is at, land on the targets; the
same program without its joint moves is compensated from the middle of the ranges and every target says so."""

from __future__ import annotations

import re

import numpy as np

from harness.programs import (
    FIXTURE,
    HOME_DEG,
    executed,
    joints,
    krl_config,
    krl_in_fixture,
    rapid_in_fixture,
    taught,
    ur5_cell,
    world_positions,
)
from models._types import Array
from programs import PROGRAM, read_program
from programs.frames import matrix_rotvec
from service.services.programs import compensate_program

N = 16


def _mixed() -> Array:
    """Joints on two wrist branches: half of them with q5 mirrored and q4, q6 turned half a turn."""
    q = joints(N, seed=13)
    q[1::2, 4] = -q[1::2, 4]
    q[1::2, 3] += np.pi
    q[1::2, 5] += np.pi
    return np.asarray((q + np.pi) % (2 * np.pi) - np.pi)  # inside the arm's ±180°


def _script(poses: Array, approach: Array | None) -> str:
    lines = ["def prog():\n"]
    for k, pose in enumerate(poses):
        if approach is not None:
            qk = ", ".join(f"{v:.6f}" for v in approach[k])
            lines.append(f"  movej([{qk}], a=1.4, v=1.05)\n")
        x, y, z = pose[:3, 3] / 1e3
        rx, ry, rz = matrix_rotvec(pose[:3, :3])
        lines.append(f"  movel(p[{x:.9f}, {y:.9f}, {z:.9f}, {rx:.9f}, {ry:.9f}, {rz:.9f}], a=1.2, v=0.25)\n")
    return "".join([*lines, "end\n"])


def test_urscript_joint_moves_fix_the_branch_of_the_moves_after_them() -> None:
    cell = ur5_cell()
    q = _mixed()
    poses = taught(cell, q)
    approach = q + np.radians(4.0) * np.sign(np.sin(np.arange(q.size).reshape(q.shape)))  # 4° away, each joint
    program = read_program("urscript", _script(poses, approach))
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal)  # no seed
    assert all(o.pose is not None for o in done.outcomes), [o.reason for o in done.outcomes]
    assert all(o.branch is not None and o.branch.startswith("the joint move at line") for o in done.outcomes)
    assert all(o.warning is None for o in done.outcomes)
    again = read_program("urscript", done.texts[PROGRAM])
    landed = executed(cell, np.array([t.pose for t in again.targets]), q)
    missed = np.linalg.norm(landed - world_positions(cell, poses), axis=1)
    assert missed.max() <= 0.05, missed


def test_without_joint_moves_every_undetermined_target_is_warned() -> None:
    cell = ur5_cell()
    q = _mixed()
    program = read_program("urscript", _script(taught(cell, q), None))
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal)
    compensated = [o for o in done.outcomes if o.pose is not None]
    assert compensated and all(o.warning is not None and "seed" in o.warning for o in compensated)
    # Solved from the middle of the ranges, the mirrored-wrist half is not on its taught branch: run from the
    # joints the robot is really at it would miss; the warning is what says so.
    seeded = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    assert all(o.warning is None and o.branch == "the request's seed" for o in seeded.outcomes)


def test_rapid_confl_off_lets_the_controller_choose_and_moveabsj_says_where_from() -> None:
    """A module whose confdata do not match the nominal solution (taught on another controller): with
    ConfL \\On (the default) each MoveL target is kept for its configuration; after ConfL \\Off and a MoveAbsJ
    to the taught joints, the controller takes the solution nearest the arm, and they are compensated."""
    cell = ur5_cell()
    q = joints(6, seed=17)
    module = rapid_in_fixture(cell, q)
    wrong = module
    for k in range(1, 7):  # every cf1 a quarter turn off
        head = f"Target_{k * 10}:="
        at = wrong.index(head)
        cf_at = wrong.index("],[", wrong.index("],[", at) + 3) + 3
        cf_end = wrong.index(",", cf_at)
        wrong = wrong[:cf_at] + str(int(wrong[cf_at:cf_end]) + 1) + wrong[cf_end:]
    held = compensate_program(cell.desc, cell.truth, read_program("rapid", wrong), nominal=cell.nominal)
    assert all(o.pose is None and "configuration" in (o.reason or "") for o in held.outcomes[1:])

    joints_deg = ",".join(f"{v:.4f}" for v in np.degrees(q[0]))
    free = wrong.replace(
        "    PROC Path_10()\r\n",
        "    PROC Path_10()\r\n"
        f"        MoveAbsJ [[{joints_deg}],[9E9,9E9,9E9,9E9,9E9,9E9]]\\NoEOffs,v1000,fine,tProbe;\r\n"
        "        ConfL \\Off;\r\n        ConfJ \\Off;\r\n",
    )
    done = compensate_program(cell.desc, cell.truth, read_program("rapid", free), nominal=cell.nominal)
    assert all(o.pose is not None for o in done.outcomes), [o.reason for o in done.outcomes]
    assert all((o.branch or "").startswith("the joint move at line") for o in done.outcomes)


def test_kuka_holds_s_and_t_on_a_ptp_only() -> None:
    """A KRL program whose T values are wrong (taught on another arm): a PTP to such a target is refused for
    its configuration, as the controller would drive another branch; a LIN keeps the configuration it starts
    in, so its T is a hint and the target is compensated."""
    cell = ur5_cell()
    q = joints(10, seed=19)
    src, dat = krl_in_fixture(cell, q)
    wrong = re.sub(r",T (\d+),", lambda m: f",T {int(m.group(1)) ^ 1},", dat)  # axis 1's sign bit flipped
    program = read_program("krl", src, {"weld.dat": wrong, "$config.dat": krl_config(FIXTURE, cell.tool)})
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    by_name = {o.target.name: o for o in done.outcomes}
    point_to_point = {f"XP{k}" for k in range(1, 11) if k % 5 == 1}  # krl_pair's PTPs
    for name, o in by_name.items():
        if name in point_to_point:
            assert o.pose is None and "configuration" in (o.reason or ""), (name, o.reason)
        else:
            assert o.pose is not None, (name, o.reason)
