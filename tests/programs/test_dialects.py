"""Valid syntax as the vendors' own files write it (issue 44): RAPID `LOCAL PROC` and the `\\a | b` alternative
parameters of ROS-Industrial's abb_driver modules, a program split over several modules, a KRC/R1 folder's
paths, and text with a UTF-8 byte order mark. Written here in those shapes; read, never refused."""

from __future__ import annotations

import numpy as np

from programs import read_program

DRIVER_STYLE = (
    "MODULE ROS_motion_server\r\n"
    "  LOCAL CONST num server_port := 11000;\r\n"
    "  LOCAL VAR robtarget pStart := [[600,0,800],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
    "  PROC main()\r\n"
    "    MoveJ pStart, v200, fine, tool0;\r\n"
    "    ROS_wait_for_client server_port, client_socket \\wait_time:=60;\r\n"
    "  ENDPROC\r\n"
    "  LOCAL PROC ROS_wait_for_client(num port, VAR socketdev client_socket, \\num wait_time)\r\n"
    "    SocketCreate client_socket;\r\n"
    "  ENDPROC\r\n"
    "  LOCAL FUNC bool is_near(robtarget a, robtarget b, \\switch On | switch Off)\r\n"
    "    RETURN TRUE;\r\n"
    "  ENDFUNC\r\n"
    "ENDMODULE\r\n"
)


def test_rapid_local_routines_and_alternative_switches_are_read() -> None:
    program = read_program("rapid", DRIVER_STYLE)
    assert [t.name for t in program.targets] == ["pStart"]
    assert program.targets[0].kept is None and np.allclose(program.targets[0].pose[:3, 3], [600, 0, 800])


def test_a_rapid_program_over_several_modules_and_a_bom() -> None:
    """Targets in one module, the tooldata and wobjdata in another, the moves in a third (a BOM in front)."""
    data = (
        "MODULE CellData\n  PERS tooldata tGun:=[TRUE,[[0,0,215.5],[1,0,0,0]],[2,[0,0,90],[1,0,0,0],0,0,0]];\n"
        '  PERS wobjdata wTable:=[FALSE,TRUE,"",[[1000,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\nENDMODULE\n'
    )
    points = (
        "MODULE Points\n  PERS robtarget p1:=[[10,20,30],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\nENDMODULE\n"
    )
    main = (
        "\ufeffMODULE MainModule\n  PROC main()\n    MoveL p1, v100, fine, tGun\\WObj:=wTable;\n  ENDPROC\nENDMODULE\n"
    )
    program = read_program("rapid", main, {"CellData.mod": data, "Points.modx": points})
    (target,) = program.targets
    assert target.file == "Points.modx" and target.kept is None
    assert target.frames.base_name == "wTable" and np.allclose(target.frames.base[:3, 3], [1000, 0, 0])
    assert target.frames.tool_name == "tGun" and target.frames.tool is not None


def test_a_krc_folder_with_its_paths() -> None:
    """A backup's files by their paths in KRC/R1: the .dat is the program, its .src and the system data beside."""
    dat = (
        "&ACCESS RVP\r\nDEFDAT  weld\r\n"
        "DECL E6POS XP1={X 900.0,Y 10.0,Z 700.0,A 0.0,B 90.0,C 0.0,S 2,T 2,E1 0.0}\r\n"
        "DECL FDAT FP1={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE}\r\nENDDAT\r\n"
    )
    src = "&ACCESS RVP\r\nDEF weld( )\r\nPTP XHOME\r\nFDAT_ACT=FP1\r\nLIN XP1\r\nEND\r\n"
    config = (
        "DEFDAT  $CONFIG\r\nDECL FRAME TOOL_DATA[16]\r\nTOOL_DATA[1]={X 0.0,Y 0.0,Z 200.0,A 0.0,B 0.0,C 0.0}\r\n"
        "E6AXIS XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 30.0,A6 0.0,E1 0.0}\r\nENDDAT\r\n"
    )
    program = read_program("krl", dat, {"KRC/R1/Program/weld.src": src, "KRC\\R1\\System\\$config.dat": config})
    (xp1,) = [t for t in program.targets if t.name == "XP1"]
    assert xp1.kept is None and xp1.frames.tool_name == "TOOL_DATA[1]"
    assert xp1.after is not None and xp1.after.line == 3 and np.allclose(np.degrees(xp1.after.joints[4]), 30.0)


def test_krl_frames_set_in_a_called_routine_hold_after_the_call() -> None:
    """Issue 44: a base and a tool set inside a subroutine were taken as the robot's base and the model's tool.
    A literal call of a routine among the files applies the frames it sets, as the controller does."""
    src = (
        "DEF cell( )\r\n"
        "  LIN XP0\r\n"
        "  SET_FRAMES( )\r\n"
        "  LIN XP1\r\n"
        "END\r\n"
        "DEF SET_FRAMES( )\r\n"
        "  $BASE = BASE_DATA[2]\r\n"
        "  $TOOL = TOOL_DATA[3]\r\n"
        "END\r\n"
    )
    dat = (
        "DEFDAT cell\r\n"
        "DECL E6POS XP0={X 900,Y 0,Z 700,A 0,B 90,C 0}\r\n"
        "DECL E6POS XP1={X 100,Y 20,Z 30,A 0,B 90,C 0}\r\n"
        "ENDDAT\r\n"
    )
    config = (
        "DEFDAT $CONFIG\r\nBASE_DATA[2]={X 1000.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\r\n"
        "TOOL_DATA[3]={X 0.0,Y 0.0,Z 150.0,A 0.0,B 0.0,C 0.0}\r\nENDDAT\r\n"
    )
    named = {t.name: t for t in read_program("krl", src, {"cell.dat": dat, "$config.dat": config}).targets}
    assert named["XP0"].frames.base_name is None and named["XP0"].frames.tool is None
    assert named["XP1"].frames.base_name == "BASE_DATA[2]" and named["XP1"].frames.tool_name == "TOOL_DATA[3]"
    assert np.allclose(named["XP1"].frames.base[:3, 3], [1000, 0, 0])


def test_urscript_pose_trans_in_a_moved_target_is_not_corrected_twice() -> None:
    """`pose_trans(Waypoint_1_p, p[offset])` is compensated in the feature's frame; where the script also moves
    to Waypoint_1_p (compensated itself), the offset's target is listed instead of corrected twice."""
    script = (
        "def f():\n"
        "  global Waypoint_1_p=p[.4, -.1, .35, 0, 3.1416, 0]\n"
        "  global Plane_1=p[.5, -.2, .05, 0, 0, 0]\n"
        "  movel(Waypoint_1_p)\n"
        "  movel(pose_trans(Waypoint_1_p, p[0, 0, -0.05, 0, 0, 0]))\n"
        "  movel(pose_trans(Plane_1, p[0.01, 0, 0.1, 0, 3.1416, 0]))\n"
        "end\n"
    )
    kept = {t.line: t.kept for t in read_program("urscript", script).targets}
    assert kept[2] is None and kept[6] is None  # the waypoint, and the pose placed in a feature
    assert "corrections would add up" in (kept[5] or "")
