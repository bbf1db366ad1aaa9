"""Only what a motion goes to changes: real-shaped cell files, where most Cartesian values are not targets.

A KUKA cell backup's shape: the program's .src and .dat, the controller's `$config.dat` (structures, enums,
signals, reference points, TOOL_CORR, LOAD_DATA, TOOL_DATA, BASE_DATA, home axes) and `$machine.dat`; the .dat
also holds a measured point, a base the program computes and writes into BASE_DATA[16], and a value used in
arithmetic. An ABB cell's: a main module, a `.sys` module with the tooldata and wobjdata (and a robtarget of its
own), a robtarget reached only through Offs, one used only in arithmetic. URScript as Polyscope and UR's own
driver scripts write it: a TCP and a feature computed at run time. Each is compensated on the UR5-like cell, and
the texts are compared line by line with what went in: only the motion targets' lines differ, every other value
is listed as "data, left alone" with its line, and no file of the controller's system data comes back."""

from __future__ import annotations

import numpy as np

from harness.programs import FIXTURE, HOME_DEG, joints, krl_in_fixture, rapid_in_fixture, ur5_cell
from models._types import Array
from programs import PROGRAM, read_program
from programs.frames import matrix_abc
from service.services.programs import compensate_program

N = 6
CONFIG_DAT = (
    "&ACCESS  RV\r\n&PARAM DISKPATH = KRC:\\R1\\System\r\n&REL 1\r\nDEFDAT  $CONFIG\r\n"
    ";FOLD BASISTECH GLOBALS\r\n"
    "INT DEF_OV_PRO=100\r\n"
    "DECL CIRC_TYPE DEF_CIRC_TYP=#BASE\r\n"
    "DECL JERK_STRUC DEF_JERK_STRUC={CP 500.000,ORI 50000.0,AX {A1 1000.00,A2 1000.00,A3 1000.00,A4 1000.00,"
    "A5 1000.00,A6 1000.00,E1 1000.00,E2 1000.00,E3 1000.00,E4 1000.00,E5 1000.00,E6 1000.00}} ; JERK\r\n"
    "ENUM BAS_COMMAND INITMOV,ACC_CP,ACC_PTP,VEL_CP,VEL_PTP,TOOL,BASE,EX_BASE,PTP_DAT,CP_DAT\r\n"
    "STRUC FDAT INT TOOL_NO,BASE_NO,IPO_MODE IPO_FRAME,CHAR POINT2[24],BOOL TQ_STATE\r\n"
    "SIGNAL STQM_SPSACTIVE $IN[1026]\r\n"
    "EXT  BAS (BAS_COMMAND  :IN,REAL  :IN )\r\n"
    'DECL FDAT FDEFAULT={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}\r\n'
    "INT DEF_GROUP[10]\r\nDEF_GROUP[1]='B1111' ; COMPLETE\r\n"
    "E6AXIS XHOME={A1 0.0,A2 -90.0000,A3 90.0000,A4 0.0,A5 0.0,A6 0.0,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}\r\n"
    "DECL FRAME REF_PT[16]\r\n"
    "REF_PT[1]={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\nREF_PT[2]={X 812.5,Y 10.0,Z 300.0,A 0.0,B 0.0,C 0.0}\r\n"
    "FRAME REF_TOOL={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\n"
    "FRAME TOOL_CORR={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\n"
    "DECL FRAME TOOL_DATA[16]\r\n"
    "{tool}"
    "TOOL_DATA[2]={X 420.390,Y 195.500,Z 259.650,A 0.0,B 0.0,C 0.0}\r\n"
    'DECL CHAR TOOL_NAME[16,24]\r\nTOOL_NAME[1,]="TOOL 1"\r\n'
    "DECL LOAD LOAD_DATA[16]\r\n"
    "LOAD_DATA[1]={M 210.000,CM {X 270.000,Y 0.0,Z 240.000,A 0.0,B 0.0,C 0.0},J {X 105.000,Y 105.000,Z 105.000}}\r\n"
    "DECL FRAME BASE_DATA[32]\r\n"
    "{base}"
    "BASE_DATA[16]={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\n"
    ";ENDFOLD\r\nENDDAT\r\n"
)
MACHINE_DAT = (
    "&ACCESS RV\r\n&REL 1\r\nDEFDAT  $MACHINE PUBLIC\r\n"
    "FRAME $ROBROOT={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\n"
    "DECL E6POS $NULLPOS={X 1000.0,Y 0.0,Z 1500.0,A 0.0,B 72.5,C 0.0,S 2,T 0,E1 0.0}\r\n"
    "ENDDAT\r\n"
)


def _abc(frame: Array) -> str:
    a, b, c = matrix_abc(frame[:3, :3])
    x, y, z = frame[:3, 3]
    return f"X {x:.4f},Y {y:.4f},Z {z:.4f},A {a:.5f},B {b:.5f},C {c:.5f}"


def _changed_lines(before: str, after: str) -> list[int]:
    a, b = before.splitlines(), after.splitlines()
    assert len(a) == len(b)
    return [k for k, (x, y) in enumerate(zip(a, b, strict=True), start=1) if x != y]


def test_a_kuka_cell_backup_changes_only_its_motion_targets() -> None:
    cell = ur5_cell()
    q = joints(N, seed=3)
    src, dat = krl_in_fixture(cell, q)
    # The program also measures a point, computes a base from it, writes it into BASE_DATA[16] and does
    # arithmetic with another value: none of these is a motion target.
    dat = dat.replace(
        "ENDDAT",
        "DECL E6POS XMEASURED={X 1200.25,Y -40.5,Z 810.0,A 10.0,B 80.0,C 5.0,S 2,T 10,E1 0.0}\r\n"
        "DECL FRAME FCOMPUTED={X 100.0,Y 20.0,Z 5.0,A 1.0,B 0.5,C 0.0}\r\n"
        "DECL POS XSHIFT={X 0.0,Y 0.0,Z 10.0,A 0.0,B 0.0,C 0.0}\r\n"
        "ENDDAT",
    )
    src = src.replace(
        "END\r\n",
        "XMEASURED=$POS_ACT\r\nBASE_DATA[16]=FCOMPUTED\r\nXMEASURED=XMEASURED:XSHIFT\r\nEND\r\n",
    )
    config = CONFIG_DAT.replace("{tool}", f"TOOL_DATA[1]={{{_abc(cell.tool)}}}\r\n").replace(
        "{base}", f"BASE_DATA[1]={{{_abc(FIXTURE)}}}\r\n"
    )
    files = {"weld.dat": dat, "$config.dat": config, "$machine.dat": MACHINE_DAT}
    program = read_program("krl", src, files)

    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    moved = {o.target.name for o in done.outcomes if o.pose is not None}
    assert moved == {f"XP{k}" for k in range(1, N + 1)}, [(o.target.name, o.reason) for o in done.outcomes]
    data = {o.target.name: o for o in done.outcomes if o.reason is not None and o.reason.startswith("data")}
    assert {"XMEASURED", "FCOMPUTED", "XSHIFT", "REF_PT[2]", "TOOL_CORR", "$NULLPOS", "$ROBROOT"} <= set(data)
    assert data["$NULLPOS"].target.file == "$machine.dat" and data["$NULLPOS"].target.line == 5
    # Text: the .dat's changed lines are exactly the XPn declarations; the .src and system files unchanged.
    assert done.texts[PROGRAM] == src
    assert done.texts["$config.dat"] == config and done.texts["$machine.dat"] == MACHINE_DAT
    changed = _changed_lines(dat, done.texts["weld.dat"])
    assert changed == sorted(o.target.line for o in done.outcomes if o.pose is not None)


def test_an_abb_cell_changes_only_what_its_moves_go_to() -> None:
    cell = ur5_cell()
    q = joints(N, seed=4)
    module = rapid_in_fixture(cell, q)
    # Its tooldata and wobjdata move to a system module, as a cell keeps them; beside them a home robtarget.
    lines = module.splitlines(keepends=True)
    frames = [line for line in lines if "tooldata" in line or "wobjdata" in line]
    main = "".join(line for line in lines if line not in frames)
    system = (
        "MODULE CellData(SYSMODULE)\r\n"
        + "".join(frames)
        + "  PERS robtarget pHomeSys:=[[500,0,600],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
        "ENDMODULE\r\n"
    )
    extra = (
        "  CONST robtarget pApproach:=[[450,10,700],[0,0.7071068,0.7071068,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
        "  VAR robtarget pMeasured:=[[440,12,690],[0,0.7071068,0.7071068,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
    )
    main = main.replace("    PROC ", extra + "    PROC ", 1)
    main = main.replace(
        "    ENDPROC",
        "        MoveL Offs(pApproach,0,0,50),v200,z10,tProbe;\r\n"
        "        pMeasured.trans.z := pMeasured.trans.z + 1;\r\n    ENDPROC",
        1,
    )
    program = read_program("rapid", main, {"celldata.sys": system})
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    moved = [o for o in done.outcomes if o.pose is not None]
    assert len(moved) == N, [(o.target.name, o.reason) for o in done.outcomes]
    reasons = {o.target.name: o.reason or "" for o in done.outcomes}
    assert "Offs" in reasons["pApproach"] and reasons["pApproach"].startswith("data, left alone")
    assert reasons["pMeasured"].startswith("data, left alone") and "system module" in reasons["pHomeSys"]
    assert done.texts["celldata.sys"] == system
    assert _changed_lines(main, done.texts[PROGRAM]) == sorted({o.target.line for o in moved})


def test_urscript_with_a_computed_tcp_and_feature_is_read_not_refused() -> None:
    """UR's driver scripts set the TCP and place poses from variables the script computes: the program is read,
    the targets that depend on them are listed with the reason, and the others are compensated."""
    script = (
        "def prog():\n"
        "  global tcp_offset = get_tcp_offset()\n"
        "  global Waypoint_1_p=p[.4, -.1, .35, 0, 3.1416, 0]\n"
        "  global feature = pose_trans(get_actual_tcp_pose(), p[0, 0, 0.1, 0, 0, 0])\n"
        "  movel(Waypoint_1_p, a=1.2, v=0.25)\n"
        "  movel(pose_trans(feature, p[0.01, 0, 0, 0, 0, 0]), a=1.2, v=0.25)\n"
        "  set_tcp(tcp_offset)\n"
        "  movel(p[.42, -.1, .35, 0, 3.1416, 0], a=1.2, v=0.25)\n"
        "  global Plane_1=p[.5, -.2, .05, 0, 0, 0]\n"
        "end\n"
    )
    program = read_program("urscript", script)
    reasons = {(t.line, t.name): t.kept for t in program.targets}
    assert reasons[(3, "Waypoint_1_p")] is None
    assert "feature computed at run time" in (reasons[(6, None)] or "")
    assert "set_tcp(tcp_offset)" in (reasons[(8, None)] or "")
    assert (reasons[(9, "Plane_1")] or "").startswith("data, left alone")
