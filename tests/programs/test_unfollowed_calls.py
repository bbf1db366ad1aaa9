"""A call of a routine whose body is not among the sent files may set a base or a tool (issue 44: "frames set in
called routines followed where the call is literal, otherwise each affected target reported with a reason").

KRL: `SET_CELL_FRAMES(2)` with no DEF among the sources may set $BASE or $TOOL (global system variables): each
target moved to after it carries a warning naming the call and its line, until the program sets the frame
itself again. Sent with the routine's .src, the call is followed and nothing is warned. Control flow (`IF (…)`)
and KRL's own functions are not routine calls."""

from __future__ import annotations

import numpy as np
import pytest

from harness.programs import HOME_DEG, ur5_cell
from programs import read_program
from programs.errors import ProgramError
from service.services.programs import compensate_program

SRC = (
    "DEF weld( )\r\n"  # line 1
    "  BAS (#INITMOV,0 )\r\n"
    "  $BASE = BASE_DATA[1]\r\n"
    "  $TOOL = TOOL_DATA[1]\r\n"
    "  PTP XP1\r\n"  # 5
    "  IF (nCount > 3) THEN\r\n"
    "    LIN XP2\r\n"
    "  ENDIF\r\n"
    "  PULSE($OUT[3], TRUE, 0.5)\r\n"
    "  SET_CELL_FRAMES(2)\r\n"  # 10
    "  LIN XP3\r\n"
    "  LIN {X 400,Y 20,Z 500,A 0,B 0,C 180}\r\n"
    "  $BASE = BASE_DATA[1]\r\n"
    "  LIN XP4\r\n"
    "  BAS (#TOOL, 1)\r\n"  # 15
    "  LIN XP5\r\n"
    "END\r\n"
)
DAT = (
    "DEFDAT weld\r\n"
    "DECL INT nCount=0\r\n"
    "DECL E6POS XP1={X 400,Y 0,Z 500,A 0,B 0,C 180,S 2,T 10,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}\r\n"
    + "".join(f"DECL E6POS XP{k}={{X {400 + 10 * k},Y 0,Z 500,A 0,B 0,C 180}}\r\n" for k in range(2, 6))
    + "ENDDAT\r\n"
)
CONFIG = (
    "DEFDAT $CONFIG\r\nDECL FRAME TOOL_DATA[16]\r\nTOOL_DATA[1]={X 0,Y 0,Z 100,A 0,B 0,C 0}\r\n"
    "DECL FRAME BASE_DATA[32]\r\nBASE_DATA[1]={X 0,Y 0,Z 0,A 0,B 0,C 0}\r\n"
    "BASE_DATA[2]={X 0,Y 50,Z 0,A 0,B 0,C 0}\r\nENDDAT\r\n"
)
CELL_FRAMES = "DEF SET_CELL_FRAMES(nBase :IN)\r\n  INT nBase\r\n  BAS (#BASE, 2)\r\nEND\r\n"


def _warnings(files: dict[str, str]) -> dict[str, str | None]:
    program = read_program("krl", SRC, files)
    return {t.name or f"line {t.line}": t.warning for t in program.targets}


def test_targets_after_a_call_not_among_the_files_are_warned_until_the_frame_is_set_again() -> None:
    found = _warnings({"weld.dat": DAT, "$config.dat": CONFIG})
    call = "after the call of SET_CELL_FRAMES( ) at line 10, a routine not among the files"
    assert found["XP1"] is None and found["XP2"] is None  # before it; IF ( ) and PULSE( ) are not routine calls
    for name in ("XP3", "line 12"):
        assert call in str(found[name]) and "$BASE or $TOOL" in str(found[name]), found[name]
    assert call in str(found["XP4"]) and "set the $TOOL," in str(found["XP4"])  # $BASE set again since
    assert found["XP5"] is None  # both set again after it


def test_the_call_is_followed_when_its_routine_is_sent() -> None:
    """With SET_CELL_FRAMES' .src among the files, BAS(#BASE, 2) is followed: XP3 is in BASE_DATA[2], unwarned."""
    program = read_program("krl", SRC, {"weld.dat": DAT, "$config.dat": CONFIG, "cell_frames.src": CELL_FRAMES})
    by_name = {t.name: t for t in program.targets}
    assert all(t.warning is None for t in program.targets)
    assert by_name["XP3"].frames.base_name == "BASE_DATA[2]" and by_name["XP3"].frames.base[1, 3] == 50.0
    assert by_name["XP2"].frames.base_name == "BASE_DATA[1]"


def test_the_warning_goes_with_the_compensated_target() -> None:
    """Compensated in the frames read before the call, the target says so beside its correction."""
    cell = ur5_cell()
    program = read_program("krl", SRC, {"weld.dat": DAT, "$config.dat": CONFIG})
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    outcome = next(o for o in done.outcomes if o.target.name == "XP3")
    assert outcome.pose is not None, outcome.reason
    assert outcome.warning is not None and "SET_CELL_FRAMES( ) at line 10" in outcome.warning
    assert next(o for o in done.outcomes if o.target.name == "XP5").warning is None


SCRIPT = (
    "def prog():\n"  # line 1
    "  global home_p=p[0.4, 0, 0.5, 0, 3.1416, 0]\n"
    "  def my_tool():\n"
    "    set_tcp(p[0, 0, 0.1, 0, 0, 0])\n"
    "  end\n"  # 5
    "  set_tool_voltage(24)\n"
    "  movel(p[0.41, 0, 0.5, 0, 3.1416, 0])\n"
    "  my_tool()\n"
    "  movel(p[0.42, 0, 0.5, 0, 3.1416, 0])\n"
    "  rg6_grip(40, 20)\n"  # 10
    "  if (True):\n"
    "    movel(home_p, a=1.2)\n"
    "  end\n"
    "  movel(p[0.43, 0, 0.5, 0, 3.1416, 0])\n"
    "  set_tcp(p[0, 0, 0.12, 0, 0, 0])\n"  # 15
    "  movel(p[0.44, 0, 0.5, 0, 3.1416, 0])\n"
    "end\n"
)


def test_urscript_a_function_the_script_does_not_define_may_set_the_tcp() -> None:
    """`rg6_grip(40, 20)` (a URCap's function, defined in the installation, not in the script) may call set_tcp:
    the moves after it are warned until the script sets the TCP itself. URScript's own functions
    (set_tool_voltage), the script's own (my_tool, read where written) and `if (…)` are not such calls."""
    by_line = {t.line: t.warning for t in read_program("urscript", SCRIPT).targets}
    call = "after the call of rg6_grip( ) at line 10, a routine not among the files: it may set the TCP"
    assert by_line[7] is None and by_line[9] is None and by_line[16] is None
    assert call in str(by_line[2]) and call in str(by_line[14])  # home_p is moved to at line 12, after the call


def test_bas_takes_its_frame_number_as_a_real_and_refuses_a_fraction() -> None:
    """BAS.SRC declares its second argument REAL: `BAS(#BASE, 2.0)` is BASE_DATA[2] as `BAS(#BASE, 2)` is (the
    program-reader fuzz found `0.0` answered a 500); `2.5` names no table entry and is a problem naming it."""
    whole = CELL_FRAMES.replace("BAS (#BASE, 2)", "BAS (#BASE, 2.0)")
    program = read_program("krl", SRC, {"weld.dat": DAT, "$config.dat": CONFIG, "cell_frames.src": whole})
    xp3 = next(t for t in program.targets if t.name == "XP3")
    assert xp3.frames.base_name == "BASE_DATA[2]" and xp3.frames.base[1, 3] == 50.0
    fraction = CELL_FRAMES.replace("BAS (#BASE, 2)", "BAS (#BASE, 2.5)")
    with pytest.raises(ProgramError, match=r"BAS's frame number 2\.5 is not a whole table index") as refused:
        read_program("krl", SRC, {"weld.dat": DAT, "$config.dat": CONFIG, "cell_frames.src": fraction})
    assert refused.value.line == 3
