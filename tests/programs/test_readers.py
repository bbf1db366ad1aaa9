"""Each dialect's reader on programs written as the vendors' tools write them: which values are targets, their
numbers and poses, the frames they are taught in, what is kept and why, and where a mistake is."""

from __future__ import annotations

import numpy as np
import pytest

from programs import ProgramSyntaxError, Target, UndeclaredFrame, read_program
from programs.frames import abc_matrix, quaternion_matrix, rotvec_matrix
from programs.urscript import LEXER as URSCRIPT_LEXER
from tests.programs.samples import CSV, KRL_CONFIG, KRL_DAT, KRL_SRC, RAPID_MOD, URSCRIPT

KRL_FILES = {"Weld_Seam.dat": KRL_DAT, "$config.dat": KRL_CONFIG}


def _by_name(targets: tuple[Target, ...]) -> dict[str | None, Target]:
    return {t.name: t for t in targets if t.name is not None}


def test_krl_targets_are_the_cartesian_values_of_the_dat_and_the_motions() -> None:
    program = read_program("krl", KRL_SRC, KRL_FILES)
    named = _by_name(program.targets)
    # E6POS, DECL-less lower-case E6POS, two POS on one GLOBAL CONST line, array elements, a FRAME; never the
    # E6AXIS home, the FDAT, the LDAT or the $config.dat frame tables.
    assert set(named) == {"XP1", "XP2", "XAUX", "XEND", "PATH[1]", "PATH[2]", "F_PROBE"}
    xp1 = named["XP1"]
    assert (xp1.file, xp1.line, xp1.column) == ("Weld_Seam.dat", 7, 16)
    assert [s.text for s in xp1.slots] == ["1224.5", "-31.2", "866.0", "-178.5", "45.25", "179.9"]
    assert np.allclose(xp1.pose[:3, 3], [1224.5, -31.2, 866.0])
    assert np.allclose(xp1.pose[:3, :3], abc_matrix(-178.5, 45.25, 179.9))
    assert xp1.configuration is not None and xp1.configuration.values == (1, 1, 0, 1, 1, 0)  # T 27
    assert named["XP2"].configuration is not None and named["XP2"].configuration.values == (0, 1, 0, 0, 0, 0)
    assert np.allclose(named["PATH[1]"].pose[:3, 3], [150, 2, 3])  # {E6POS: X 1.5E2, ...}


def test_krl_frames_follow_the_statements_fdat_and_config_dat() -> None:
    named = _by_name(read_program("krl", KRL_SRC, KRL_FILES).targets)
    xp1 = named["XP1"]  # FDAT_ACT=FP1: TOOL_NO 1, BASE_NO 2
    assert (xp1.frames.base_name, xp1.frames.tool_name) == ("BASE_DATA[2]", "TOOL_DATA[1]")
    assert np.allclose(xp1.frames.base[:3, 3], [1500, -300, 0])
    assert xp1.frames.tool is not None and np.allclose(xp1.frames.tool[:3, 3], [12.5, 0, 310])
    assert np.allclose(xp1.frames.tool[:3, :3], abc_matrix(0, -30, 0))
    # after `$TOOL = TOOL_DATA[1]` and `$BASE=$NULLFRAME`: the robot's base
    assert named["XEND"].frames.base_name == "$NULLFRAME" and np.allclose(named["XEND"].frames.base, np.eye(4))
    assert named["PATH[2]"].frames.tool_name == "TOOL_DATA[1]"
    # a value no motion names: data, left alone (a measured point is not a target)
    assert named["F_PROBE"].kept is not None and named["F_PROBE"].kept.startswith("data, left alone")


def test_krl_keeps_partial_relative_and_joint_values() -> None:
    inline = [t for t in read_program("krl", KRL_SRC, KRL_FILES).targets if t.name is None]
    assert [(t.line, t.column) for t in inline] == [(23, 5), (25, 5), (28, 9)]  # never the PTP {A1 ...}
    whole, partial, relative = inline
    assert whole.kept is None and np.allclose(whole.pose[:3, 3], [850.5, -120.25, 640])
    assert partial.kept is not None and "Z, A, B, C omitted" in partial.kept
    assert relative.kept is not None and "relative" in relative.kept


def test_krl_an_undeclared_base_is_refused_where_it_is_used() -> None:
    with pytest.raises(UndeclaredFrame) as info:
        read_program("krl", KRL_SRC, {"Weld_Seam.dat": KRL_DAT})  # no $config.dat: TOOL_DATA[1] unknown
    assert info.value.line == 16 and info.value.data["reason"] == "undeclared-frame"
    assert "TOOL_DATA[1]" in info.value.detail


@pytest.mark.parametrize(
    ("line", "column", "what"),
    [
        ("DECL E6POS XP9={X 1,Y 2,,Z 3}", 25, "expected name"),
        ("DECL E6POS XP9={X 1,Y 2,Z}", 26, "value is missing"),
        ("DECL E6POS XP9={X 1,X 2}", 21, "twice"),
        ("DECL POS XP9={X 1,Y 2", 21, "ends early"),
    ],
)
def test_krl_a_syntax_error_in_a_target_names_its_line_and_column(line: str, column: int, what: str) -> None:
    with pytest.raises(ProgramSyntaxError) as info:
        read_program("krl", "DEF a( )\r\nEND\r\n", {"a.dat": f"DEFDAT a\r\n{line}\r\nENDDAT\r\n"})
    assert (info.value.file, info.value.line, info.value.column) == ("a.dat", 2, column)
    assert what in info.value.detail


def test_rapid_targets_tools_and_work_objects() -> None:
    program = read_program("rapid", RAPID_MOD, {})
    named = _by_name(program.targets)
    assert set(named) == {"pApproach", "pWeld{1}", "pWeld{2}", "pLast"}  # never the jointtarget or pTemp
    approach = named["pApproach"]
    assert (approach.line, approach.column) == (9, 38)
    assert [s.text for s in approach.slots][:3] == ["250.1", "-12.30", "400.00"]
    assert np.allclose(approach.pose[:3, :3], quaternion_matrix([0.00428, -0.70709, 0.70711, 0.00428]))
    assert approach.configuration is not None and approach.configuration.values == (-1, 0, -1)
    assert (approach.frames.base_name, approach.frames.tool_name) == ("wobjTable", "tGun")
    # uframe · oframe: 1200, -400, 250, then 10, 20 turned by nothing (uframe's identity)
    assert np.allclose(approach.frames.base[:3, 3], [1210, -380, 250])
    assert np.allclose(approach.frames.base[:3, :3], quaternion_matrix([0.707107, 0, 0, 0.707107]), atol=1e-6)
    assert approach.frames.tool is not None and np.allclose(approach.frames.tool[:3, 3], [0, 0, 215.5])
    assert named["pWeld{2}"].line == 12  # the array's second element, on its own line
    inline = [t for t in program.targets if t.name is None]
    assert [(t.line, t.frames.tool_name) for t in inline] == [(23, "tool0"), (26, "tool0"), (27, "tool0")]


def test_rapid_an_undeclared_tool_and_a_malformed_robtarget_are_refused() -> None:
    with pytest.raises(UndeclaredFrame) as info:
        read_program("rapid", RAPID_MOD.replace("tGun\\WObj:=wobjTable;", "tTorch\\WObj:=wobjTable;", 1), {})
    assert (info.value.line, info.value.data["reason"]) == (20, "undeclared-frame")
    broken = RAPID_MOD.replace("[[300,0,50],[0,0,1,0]", "[[300,0],[0,0,1,0]")
    with pytest.raises(ProgramSyntaxError) as syntax:
        read_program("rapid", broken, {})
    assert (syntax.value.line, syntax.value.column) == (11, 10)
    assert "position has 3 values" in syntax.value.detail


def test_urscript_targets_features_and_the_tcp() -> None:
    program = read_program("urscript", URSCRIPT, {})
    data = [t for t in program.targets if t.kept is not None and t.kept.startswith("data, left alone")]
    assert [t.name for t in data] == ["Plane_1"]  # a feature: listed with its line, never moved
    targets = tuple(t for t in program.targets if t not in data)
    assert [t.name for t in targets if t.name] == ["Waypoint_1_p", "Waypoint_2_p"]  # never Plane_1, the TCP
    assert len(targets) == 7  # 2 waypoints, pose_trans, movep, movec's two, the non-literal one
    w1 = targets[0]
    assert np.allclose(w1.pose[:3, 3], [400, -100, 350]) and np.allclose(w1.pose[:3, :3], rotvec_matrix([0, 3.1416, 0]))
    assert w1.frames.tool is not None and np.allclose(w1.frames.tool[:3, 3], [0, 0, 215.5])
    in_plane = targets[2]
    assert in_plane.frames.base_name == "Plane_1" and np.allclose(in_plane.frames.base[:3, 3], [500, -200, 50])
    assert targets[-1].kept is not None and "not literal" in targets[-1].kept


def test_csv_rows_are_targets_and_a_bad_number_names_its_place() -> None:
    targets = read_program("csv", CSV, {}).targets
    assert [t.name for t in targets] == ["P1", "P 2", "P3"]
    assert [t.line for t in targets] == [3, 4, 6]
    assert np.allclose(targets[2].pose[:3, 3], [1000, 5, 6])
    assert [s.text for s in targets[1].slots][:2] == ["900.000", "0"]  # inside its quotes
    with pytest.raises(ProgramSyntaxError) as info:
        read_program("csv", CSV.replace("P3;1.0E3", "P3;1.0E3x"), {})
    assert (info.value.line, info.value.column) == (6, 4)
    with pytest.raises(ProgramSyntaxError, match="lacks x, y, z"):
        read_program("csv", "name,x,y\r\nP,1,2\r\n", {})


@pytest.mark.parametrize(
    ("format_name", "text"),
    [
        ("krl", "DEFDAT a\r\nDECL E6POS P={X " + "{X " * 5000 + "1" + "}" * 5001 + "\r\nENDDAT\r\n"),
        ("rapid", "MODULE m\r\nCONST robtarget p:=" + "[" * 5000 + "1" + "]" * 5000 + ";\r\nENDMODULE\r\n"),
    ],
)
def test_hostile_nesting_is_a_syntax_error_not_a_crash(format_name: str, text: str) -> None:
    with pytest.raises(ProgramSyntaxError, match="nested more than"):
        read_program(format_name, text, {})


def test_token_lines_and_columns_count_characters_after_every_kind_of_line_end() -> None:
    # Hand-counted: a CRLF line, a string with an escaped quote, a backslash continuation, then the tokens.
    text = 'a = 1\r\nb = "x\\"y" c\n  d \\\n  e\n'
    found = [(t.text, t.line, t.column) for t in URSCRIPT_LEXER.tokens(text)]
    assert found == [
        ("a", 1, 1),
        ("=", 1, 3),
        ("1", 1, 5),
        ("b", 2, 1),
        ("=", 2, 3),
        ('"x\\"y"', 2, 5),
        ("c", 2, 12),
        ("d", 3, 3),
        ("e", 4, 3),
    ]
    assert all(text[t.start : t.end] == t.text for t in URSCRIPT_LEXER.tokens(text))


@pytest.mark.parametrize(
    ("text", "line", "column", "char"),
    [("@", 1, 1, "@"), ("movel(p)\n  x = 1 ` 2", 2, 9, "`"), ("a\r\n\r\n\t?", 3, 2, "?")],
)
def test_an_unexpected_character_is_named_with_its_line_and_column(
    text: str, line: int, column: int, char: str
) -> None:
    with pytest.raises(ProgramSyntaxError) as raised:
        URSCRIPT_LEXER.tokens(text, "prog.script")
    assert (raised.value.line, raised.value.column, raised.value.file) == (line, column, "prog.script")
    assert repr(char) in str(raised.value)
