"""Absurd but finite numbers are listed with a reason naming the number, not compensated (issue 44).

A KRL `A 1e300` or a URScript rotation vector of length 1e300 used to be "compensated": cos(1e300°) is floating-
point noise, so the answer was a meaningless pose written back into the program. Each dialect's reader now keeps
such a target as written with the number in its reason: angles beyond `ABSURD_TURNS` (4) turns, positions beyond
`ABSURD_MM` (100 m) from their base. Just inside those bounds, the same target is compensated."""

from __future__ import annotations

import numpy as np
import pytest

from harness.programs import HOME_DEG, ur5_cell
from programs import read_program
from programs.targets import ABSURD_MM, ABSURD_TURNS
from service.services.programs import compensate_program

CELL = ur5_cell()
SEED = np.radians(HOME_DEG)

RAPID = (
    "MODULE M\r\n  CONST robtarget p:=[[{x},0,500],[{q}],[1,1,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
    "  PROC main()\r\n    MoveL p,v100,fine,tool0;\r\n  ENDPROC\r\nENDMODULE\r\n"
)
# A reachable pose of the UR5-like arm (TCP down, 400 mm out, 500 mm up) in each dialect's own numbers.
ABSURD = [
    ("krl", "DEF a()\r\nLIN {X 400,Y 0,Z 500,A 1e300,B 0,C 180}\r\nEND\r\n", "A = 1e300° is 2.78e+297 turns"),
    ("krl", "DEF a()\r\nLIN {X 400,Y 0,Z 500,A 1475,B 0,C 180}\r\nEND\r\n", "A = 1475° is 4.1 turns"),
    ("krl", "DEF a()\r\nLIN {X 4E8,Y 0,Z 500,A 0,B 0,C 180}\r\nEND\r\n", "x = 4E8 is 4e+05 m from its base"),
    ("urscript", "def a():\n  movel(p[0.4,0,0.5,1e300,0,0])\nend\n", "[1e300, 0, 0] (length 1e+300 rad)"),
    ("urscript", "def a():\n  movel(p[0.4,0,0.5,0,26,0])\nend\n", "[0, 26, 0] (length 26 rad) is 4.14 turns"),
    ("urscript", "def a():\n  movel(p[0.4,0,500,0,3.1416,0])\nend\n", "z = 500 is 500 m from its base"),
    ("rapid", RAPID.format(x=400, q="0,0,1e300,0"), "the quaternion [0, 0, 1e300, 0] has norm 1e+300"),
    ("rapid", RAPID.format(x=400, q="0,0,2.5,0"), "the quaternion [0, 0, 2.5, 0] has norm 2.5"),
    ("rapid", RAPID.format(x="1.2e6", q="0,0,1,0"), "x = 1.2e6 is 1.2e+03 m from its base"),
    ("csv", "x,y,z,a,b,c\r\n400,0,500,0,0,-1e300\r\n", "C = -1e300° is 2.78e+297 turns"),
    ("csv", "x,y,z,rx,ry,rz\r\n400,0,500,0,1e300,0\r\n", "[0, 1e300, 0] (length 1e+300°)"),
    ("csv", "x,y,z,qw,qx,qy,qz\r\n400,0,500,0,0,1,1e300\r\n", "the quaternion [0, 0, 1, 1e300]"),
]
# The same targets with plausible numbers near the bounds: compensated.
PLAUSIBLE = [
    ("krl", "DEF a()\r\nLIN {X 400,Y 0,Z 500,A 1400,B 0,C 180}\r\nEND\r\n"),  # 3.9 turns: a wound-up A
    ("urscript", "def a():\n  movel(p[0.4,0,0.5,0,3.1416,0])\nend\n"),
    ("rapid", RAPID.format(x=400, q="0,0,1,0")),
    ("csv", "x,y,z,a,b,c\r\n400,0,500,0,0,180\r\n"),
]


@pytest.mark.parametrize(("fmt", "text", "named"), ABSURD, ids=[f"{f}-{k}" for k, (f, _, _) in enumerate(ABSURD)])
def test_an_absurd_number_is_listed_naming_it_and_the_text_kept(fmt: str, text: str, named: str) -> None:
    with np.errstate(all="ignore"):  # as the service reads: 1e300 overflows on the way to a (NaN) pose
        program = read_program(fmt, text)
    (target,) = program.targets
    assert target.kept is not None and named in target.kept, target.kept
    with np.errstate(all="ignore"):
        done = compensate_program(CELL.desc, CELL.truth, program, nominal=CELL.nominal, seed=SEED)
    (outcome,) = done.outcomes
    assert outcome.pose is None and outcome.reason == target.kept
    assert done.texts[None] == text  # not a character changed


@pytest.mark.parametrize(("fmt", "text"), PLAUSIBLE, ids=[f for f, _ in PLAUSIBLE])
def test_a_plausible_number_near_the_bounds_is_compensated(fmt: str, text: str) -> None:
    program = read_program(fmt, text)
    (target,) = program.targets
    assert target.kept is None
    done = compensate_program(CELL.desc, CELL.truth, program, nominal=CELL.nominal, seed=SEED)
    (outcome,) = done.outcomes
    assert outcome.pose is not None, outcome.reason
    assert done.texts[None] != text


def test_the_bounds_are_far_beyond_what_controllers_write() -> None:
    """100 m is 25 times the reach of the largest arms (~4 m); 4 turns is 8 times KUKA's ±180°."""
    assert ABSURD_MM >= 25 * 4_000 and ABSURD_TURNS * 360 >= 8 * 180
