"""RAPID: the motions beside Move* (Trigg, Search, Arc, Spot, Paint) are read where their manuals put the
robtargets, the tool and `\\WObj`, and a robtarget the program changes at run time is never compensated as if
its literal were where the robot goes (issue 44).

- TriggL/J/C, TriggLIOs, SearchL/C, ArcL/C and their Start/End, SpotL/J and PaintL/C: each target compensated
  exactly in the instruction's tool and work object (a target read in tool0 or wobj0 misses by centimetres).
- A motion of an option whose layout the reader does not know (DispL, CapL, SpotML, ...), or a Spot or Arc
  instruction whose last argument is no tooldata: its targets are kept, named "a motion the reader does not
  know the layout of".
- A robtarget written at run time (a field, CRobT, Offs, another robtarget, SearchL's SearchPoint,
  SetDataVal, GetDataVal, a routine of the files writing its INOUT parameter) or given two different literals:
  every motion to it is kept, the reason naming the line and the statement.

The modules are written as the FlexPendant saves them (`%%%` header, CRLF); the targets come from the
UR5-like cell's nominal controller, and the compensated ones are run by it on the "true" robot."""

from __future__ import annotations

import numpy as np
import pytest

from harness.programs import (
    HOME_DEG,
    ProbeTargets,
    flexpendant_header,
    joints,
    rapid_cell_module,
    ur5_cell,
)
from programs import PROGRAM, ProgramError, Target, read_program
from service.services.programs import compensate_program

CELL = ur5_cell()
MOTIONS = (
    ("TriggL {0}, v500, trOn \\T2:=trOff, z10, tProbe \\WObj:=wFixture;", True),
    ("TriggJ {0}, v500, trOn, fine, tProbe;", False),
    ("TriggC {0}, {1}, v500, trOn, z10, tProbe \\WObj:=wFixture;", True),
    ("TriggLIOs {0}, v500 \\TriggData1:=ios1, z10, tProbe \\WObj:=wFixture;", True),
    ("SearchL \\Stop, diTouch, pFound, {0}, v50, tProbe \\WObj:=wFixture;", True),
    ("SearchC \\Sup, diTouch \\Flanks, pFound, {0}, {1}, v50, tProbe;", False),
    ('ArcLStart {0}, v100, seam1, weld1 \\Weave:=weave1, fine, tProbe \\WObj:=wFixture \\SeamName:="S1";', True),
    ("ArcL {0}, v20, seam1, weld1, weave1, z1, tProbe \\WObj:=wFixture;", True),
    ("ArcCEnd {0}, {1}, v20, seam1, weld1, fine, tProbe \\WObj:=wFixture;", True),
    ("SpotL {0}, vmax, spot1 \\InPos, tProbe \\WObj:=wFixture;", True),
    ("SpotJ {0}, vmax, gun1, spot1, tProbe;", False),
    ("PaintL {0}, v500, z10, tProbe \\WObj:=wFixture;", True),
    ("PaintC {0}, {1}, v500, z10, tProbe;", False),
)
"""Each motion as the option's manual writes it, its robtargets `{k}`, and whether it names wFixture (else
wobj0). The SpotJ is SpotWare's older form, with the gun before the spot; the ArcL the one with a weave."""
COUNT = sum(text.count("{") for text, _ in MOTIONS)
Q = joints(COUNT, seed=33)
IN_FIXTURE = [fixture for text, fixture in MOTIONS for _ in range(text.count("{"))]


TARGETS = ProbeTargets(CELL, Q, IN_FIXTURE)
CELL_SYS = rapid_cell_module(
    CELL,
    "  PERS seamdata seam1:=[0.5,0.5,[5,0,24,120,0,0,0,0,0],0.5,1,2,0,0,[5,0,24,120,0,0,0,0,0]];\r\n",
    '  PERS gundata gun1:=["gun1",1,2,0.5,0.5,FALSE,0,0,0];\r\n',
)
HEADER = flexpendant_header("Process")


def _data(count: int = COUNT) -> str:
    """Module lines 7..: the robtargets p1..p{count}, then pFound (a SearchPoint) and other data."""
    return "".join(f"  PERS robtarget p{k + 1}:={TARGETS.robtarget(k)};\r\n" for k in range(count)) + (
        f"  PERS robtarget pFound:={TARGETS.robtarget(0)};\r\n"
        "  VAR triggdata trOn;\r\n  VAR triggdata trOff;\r\n  VAR triggios ios1{1};\r\n"
    )


def _module(body: list[str], count: int = COUNT) -> str:
    return (
        HEADER
        + _data(count)
        + "  PROC main()\r\n"
        + "".join(f"    {b}\r\n" for b in body)
        + "  ENDPROC\r\nENDMODULE\r\n"
    )


def _all_motions() -> list[str]:
    lines, k = [], 0
    for text, _ in MOTIONS:
        n = text.count("{")
        lines.append(text.format(*[f"p{k + j + 1}" for j in range(n)]))
        k += n
    return lines


def _read(module: str, **files: str) -> dict[str, Target]:
    program = read_program("rapid", module, {"celldata.sys": CELL_SYS, **files})
    return {t.name or f"line {t.line}": t for t in program.targets}


def test_each_process_motion_is_compensated_exactly_in_its_tool_and_work_object() -> None:
    """18 targets, one or two per instruction; each, run by the nominal controller on the true robot after the
    compensation, lands within 0.05 mm of where it was taught (before: millimetres off). Read in tool0 or in
    wobj0, the tool's 50-100 mm offset or the fixture's frame would send it centimetres away."""
    module = _module(_all_motions())
    program = read_program("rapid", module, {"celldata.sys": CELL_SYS})
    named = {t.name: t for t in program.targets}
    for k in range(COUNT):
        target = named[f"p{k + 1}"]
        assert target.kept is None, (k, target.kept)
        assert target.frames.tool_name == "tProbe"
        assert target.frames.base_name == ("wFixture" if IN_FIXTURE[k] else "wobj0"), k
    assert "data, left alone" in str(named["pFound"].kept)  # a SearchPoint, no motion goes to it
    done = compensate_program(CELL.desc, CELL.truth, program, nominal=CELL.nominal, seed=np.radians(HOME_DEG))
    again = {t.name: t for t in read_program("rapid", done.texts[PROGRAM], {"celldata.sys": CELL_SYS}).targets}
    for k in range(COUNT):
        after, before = TARGETS.misses(k, again[f"p{k + 1}"].pose)
        assert after <= 0.05, (k, after)
        assert before > 0.5, k
    changed = [
        n
        for n, (a, b) in enumerate(zip(module.splitlines(), done.texts[PROGRAM].splitlines(), strict=True), 1)
        if a != b
    ]
    assert changed == list(range(7, 7 + COUNT))  # the robtargets' declarations, and nothing else


@pytest.mark.parametrize(
    "motion",
    [
        "DispL \\On, {0}, v100, bead1, z10, tProbe \\WObj:=wFixture;",
        "CapL {0}, v100, cdata1, weavestart1, weave1, z10, tProbe;",
        "SpotML {0}, vmax \\G1:=spot1 \\G2:=spot2, tProbe;",
        "ArcL1 {0}, v100, seam1, weld1, fine, tProbe;",
        "SpotL {0}, vmax, spot1, gun1;",
    ],
)
def test_a_motion_of_an_unknown_layout_keeps_its_targets(motion: str) -> None:
    """p1 is also moved to by a MoveL (line 15, read): one value cannot be compensated for one motion and left
    for another; p2 only by MoveL: compensated. A robtarget written inside the motion is kept too. The last
    SpotL names a gundata where the tool should be: a version of SpotL the reader does not know."""
    inline = TARGETS.robtarget(2)
    body = ["MoveL p1, v500, z10, tProbe \\WObj:=wFixture;", "MoveL p2, v500, z10, tProbe;", motion.format("p1")]
    body.append(motion.format(inline))
    found = _read(_module(body, count=3))
    why = f"moved to by `{motion.format('p1')}` (line 17), a motion the reader does not know the layout of"
    assert why in str(found["p1"].kept), found["p1"].kept
    assert "a motion the reader does not know the layout of" in str(found["line 18"].kept)
    assert found["p2"].kept is None and found["p2"].warning is None


@pytest.mark.parametrize(
    ("statement", "how"),
    [
        ("p1.trans.z := p1.trans.z + 5;", ""),
        ("p1 := CRobT(\\Tool:=tProbe \\WObj:=wFixture);", ""),
        ("p1 := Offs(p2, 0, 0, 10);", ""),
        ("p1 := p2;", ""),
        ("SearchL \\Stop, diTouch, p1, p2, v50, tProbe;", ""),
        ('SetDataVal "p1", p2;', ""),
        ('GetDataVal "pFound", p1;', ""),
        ("Teach p1;", ", where Teach writes its parameter p"),
    ],
)
def test_a_robtarget_changed_at_run_time_keeps_every_motion_to_it(statement: str, how: str) -> None:
    """The change at line 15, before or after the motions alike (the reader does not follow the order the
    controller runs them in). p2 (read, moved to, never written) stays compensated."""
    teach = "MODULE Teaching\r\n  PROC Teach(INOUT robtarget p)\r\n    p := CRobT();\r\n  ENDPROC\r\nENDMODULE\r\n"
    body = [statement, "TriggL p1, v500, trOn, z10, tProbe \\WObj:=wFixture;", "MoveL p2, v500, z10, tProbe;"]
    found = _read(_module(body, count=3), **{"teach.mod": teach})
    assert f"robtarget p1 is changed at run time by `{statement}` (line 15){how}" in str(found["p1"].kept)
    assert "the point the robot goes to is known only then" in str(found["p1"].kept)
    assert found["p2"].kept is None and found["p3"].kept is not None  # p3: no motion goes to it


def test_an_array_element_written_keeps_that_element_and_two_literals_keep_both() -> None:
    """`path{2} := CRobT();` keeps path{2}, not path{1}; p1 given another literal at line 20 keeps both of its
    values (its declaration at line 7 too); p2 given its own value again, written otherwise, does not."""
    path = f"  VAR robtarget path{{2}}:=[{TARGETS.robtarget(0)},{TARGETS.robtarget(1)}];\r\n"
    moved = TARGETS.robtarget(2)
    same = TARGETS.robtarget(1).replace("9E+09", "9E9").replace("],[", "], [", 1)
    body = [
        "path{2} := CRobT();",
        "MoveL path{1}, v500, z10, tProbe \\WObj:=wFixture;",
        "MoveL path{2}, v500, z10, tProbe \\WObj:=wFixture;",
        "MoveL p1, v500, z10, tProbe \\WObj:=wFixture;",
        f"p1 := {moved};",
        f"p2 := {same};",
        "MoveL p2, v500, z10, tProbe;",
    ]
    module = _module(body, count=3).replace("  PROC main()", path + "  PROC main()")
    program = read_program("rapid", module, {"celldata.sys": CELL_SYS})
    by_line = {(t.name, t.line): t for t in program.targets}
    assert by_line[("path{1}", 14)].kept is None
    assert "robtarget path{2} is changed at run time by `path{2} := CRobT();` (line 16)" in str(
        by_line[("path{2}", 14)].kept
    )
    both = "robtarget p1 is given two different values (line 7 and line 20)"
    assert both in str(by_line[("p1", 7)].kept) and both in str(by_line[("p1", 20)].kept)
    assert by_line[("p2", 8)].kept is None and by_line[("p2", 21)].kept is None


def test_a_call_not_followed_says_the_targets_are_compensated_in_the_frames_read() -> None:
    found = _read(_module(["GripperOpen;", "TriggL p1, v500, trOn, z10, tProbe \\WObj:=wFixture;"], count=1))
    assert "after the call of GripperOpen at line 13" in str(found["p1"].warning)
    assert "compensated in the frames read (send the file that defines it)" in str(found["p1"].warning)


def test_a_process_motion_missing_an_argument_is_refused_naming_its_layout() -> None:
    with pytest.raises(ProgramError, match=r"TriggL takes ToPoint, Speed, Trigg_1, Zone, Tool"):
        read_program("rapid", _module(["TriggL p1, v500, z10, tProbe;"], count=1), {"celldata.sys": CELL_SYS})
