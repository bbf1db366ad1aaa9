"""Property-based fuzz of the program readers (issue 48): whatever text comes, a reader answers a `Program` or a
`ProgramError` (a 4xx naming the place), never another exception (a 500). The texts are built from each
dialect's own pieces (keywords, brackets, numbers up to 1e400, names, comments, line ends) shuffled with
arbitrary characters, so that most examples get deep into the grammar rather than failing at the first byte;
whatever reads is also rewritten with its own poses, which must succeed and keep every other character."""

from __future__ import annotations

import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from harness.programs import Cell, ur5_cell
from programs import PROGRAM, ProgramError, read_program, rewritten
from service.services.programs import compensate_program

NUMBERS = st.one_of(
    st.integers(-10_000, 10_000).map(str),
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr),
    st.sampled_from(["1e400", "-1E+400", "9E9", ".5", "1.", "0" * 320 + "1", "1" + "0" * 320, "1e-400", "1e308"]),
)
PIECES = {
    "krl": [
        "DEF a( )",
        "END",
        "DEFDAT d",
        "ENDDAT",
        "DECL",
        "GLOBAL",
        "CONST",
        "E6POS",
        "POS",
        "FRAME",
        "E6AXIS",
        "FDAT",
        "PTP",
        "LIN",
        "CIRC",
        "SLIN",
        "LIN_REL",
        "BAS(#BASE,",
        "BAS(#TOOL,",
        "$BASE",
        "$TOOL",
        "=",
        "BASE_DATA[",
        "TOOL_DATA[",
        "FDAT_ACT",
        "XP1",
        "XP2",
        "{",
        "}",
        "X",
        "Y",
        "Z",
        "A",
        "B",
        "C",
        "S",
        "T",
        "E1",
        ",",
        ":",
        "[",
        "]",
        "(",
        ")",
        "'B010'",
        '"s"',
        ";c",
        "&ACCESS RVP",
        "#TCP",
        "IPO_FRAME",
        "TOOL_NO",
        "BASE_NO",
        "$NULLFRAME",
    ],
    "rapid": [
        "MODULE M",
        "ENDMODULE",
        "PROC main()",
        "ENDPROC",
        "LOCAL",
        "TASK",
        "CONST",
        "PERS",
        "VAR",
        "robtarget",
        "tooldata",
        "wobjdata",
        "p10",
        "t1",
        "w1",
        ":=",
        "[",
        "]",
        "{",
        "}",
        ",",
        ";",
        "MoveL",
        "MoveJ",
        "MoveC",
        "Offs(",
        "RelTool(",
        ")",
        "\\WObj:=",
        "\\Conc",
        "v100",
        "fine",
        "z10",
        "tool0",
        "wobj0",
        "TRUE",
        "FALSE",
        '"x"',
        "!c",
        "9E9",
        ".",
        "%%%",
    ],
    "urscript": [
        "def f():",
        "end",
        "global",
        "p[",
        "]",
        "[",
        "(",
        ")",
        ",",
        "=",
        "movel(",
        "movej(",
        "movep(",
        "movec(",
        "servoc(",
        "set_tcp(",
        "pose_trans(",
        "pose_add(",
        "get_inverse_kin(",
        "Waypoint_1_p",
        "Plane_1",
        "a=1",
        "v=0.25",
        "#c",
        "'s'",
        "if",
        "else:",
        "while",
        "True:",
    ],
    "csv": ["x", "y", "z", "a", "b", "c", "qw", "qx", "qy", "qz", "rx", "ry", "rz", "name", ",", ";", '"', "#c"],
}
BREAKS = st.sampled_from(["\n", "\r\n", " ", "  ", "\t", ""])


def _texts(dialect: str) -> st.SearchStrategy[str]:
    piece = st.one_of(st.sampled_from(PIECES[dialect]), NUMBERS, st.text(max_size=3))
    return st.lists(st.tuples(piece, BREAKS), max_size=60).map(lambda parts: "".join(p + b for p, b in parts))


def _read_or_refuse(dialect: str, text: str, files: dict[str, str] | None = None) -> None:
    try:
        program = read_program(dialect, text, files or {})
    except ProgramError as exc:
        assert str(exc), "a refusal says what is wrong"
        return
    poses = [t for t in program.targets if np.isfinite(t.pose).all() and t.kept is None]
    out = rewritten(program, [(t, t.pose) for t in poses])
    assert set(out) == set(program.texts)
    if not poses:
        assert out[PROGRAM] == text  # nothing to change: every character kept


FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.slow  # four dialects, ~150 examples each: several seconds
@pytest.mark.parametrize("dialect", ["krl", "rapid", "urscript", "csv"])
def test_a_reader_answers_a_program_or_a_problem_for_any_text(dialect: str) -> None:
    @FUZZ
    @given(text=_texts(dialect))
    def check(text: str) -> None:
        _read_or_refuse(dialect, text)

    check()


@pytest.mark.slow
@given(dat=_texts("krl"), config=_texts("krl"))
@FUZZ
def test_krl_companion_files_are_read_or_refused(dat: str, config: str) -> None:
    _read_or_refuse("krl", "DEF a( )\nPTP XP1\nLIN XP2\nEND\n", {"a.dat": dat, "$config.dat": config})


@pytest.mark.parametrize("dialect", ["krl", "rapid", "urscript", "csv"])
@pytest.mark.parametrize("number", ["1e400", "-1E+400", "1" + "0" * 320])
def test_the_overflows_the_probe_found_are_problems(dialect: str, number: str) -> None:
    """The probe's finds (issue 48), kept as plain cases: a number past a double in each dialect's target is a
    syntax problem at its line, not an infinity that fails later as a 500."""
    text = {
        "krl": f"DEF a()\nLIN {{X {number}, Y 0, Z 0, A 0, B 0, C 0}}\nEND\n",
        "rapid": "MODULE M\nPROC main()\n"
        f"MoveL [[{number},0,0],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v1,fine,tool0;\nENDPROC\nENDMODULE\n",
        "urscript": f"def f():\n  movel(p[{number}, 0, 0, 0, 0, 0])\nend\n",
        "csv": f"x,y,z,a,b,c\n{number},0,0,0,0,0\n",
    }[dialect]
    with pytest.raises(ProgramError) as info:
        read_program(dialect, text)
    assert info.value.line == (3 if dialect == "rapid" else 2)
    assert info.value.column is not None


@pytest.fixture(scope="module")
def cell() -> Cell:
    return ur5_cell()


NUMBER_VALUES = st.one_of(
    st.floats(-2_000, 2_000, allow_nan=False),
    st.sampled_from([0.0, 1e300, -1e300, 1e-300, 9e9]),
)


@pytest.mark.slow  # 50 compensations of random targets (unreachable ones try IPOPT until the deadline): ~20 s
@given(rows=st.lists(st.lists(NUMBER_VALUES, min_size=7, max_size=7), min_size=1, max_size=3))
@settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_any_target_that_reads_is_compensated_or_listed(cell: Cell, rows: list[list[float]]) -> None:
    """The numbers that read (any finite double, in a CSV of quaternions) go through the compensation as the
    service runs it: every target comes back compensated or with a reason, never an exception (the 1e300
    targets and zero quaternions this found are now listed)."""
    text = "x,y,z,qw,qx,qy,qz\n" + "".join(",".join(repr(v) for v in row) + "\n" for row in rows)
    with np.errstate(all="ignore"):  # as the service reads and compensates
        program = read_program("csv", text)
        done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, deadline=time.monotonic() + 0.5)
    assert len(done.outcomes) == len(rows)
    assert all((o.pose is not None) != (o.reason is not None) for o in done.outcomes)
