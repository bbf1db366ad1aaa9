"""ABB RAPID: the robtargets of .mod / .prg modules.

A robtarget is `[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], [eax_a, ..., eax_f]]`: the TCP in mm in the
work object's object frame, a unit quaternion with q1 the scalar, the configuration (quarter turns of axes 1,
4 and 6, and the arm's configuration number) and the external axes (9E9 where none). The targets are the
robtarget data (CONST, PERS or VAR; LOCAL or TASK; arrays `{n}` by element; values given with `:=` in a
declaration or an assignment) and the robtargets written inside motions (Move*, and the Trigg, Search, Arc,
Spot and Paint motions, each where `rapid_statements.LAYOUTS` puts its targets and its tool). A motion's tool
(`tooldata`, its tframe) and its work object (`\\WObj:=`, uframe · oframe of the `wobjdata`) are the frames it is
taught in; `tool0` is the flange and `wobj0` the robot's base. A tooldata, wobjdata or robtarget the program
changes at run time (other than by one literal value), a program displacement in force (PDispOn, PDispSet)
and a motion whose layout the reader does not know keep the targets moved to with them; a call of a routine
no sent module defines warns the motions after it (docs/controller.md, "Frames").
jointtargets, speeds, zones and every other datum are kept as written. `!` starts a comment; statements end
with `;` and may span lines.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple, TypeVar

import numpy as np

from models._types import Array
from programs.aggregates import Number, Opaque, Value, literal_or_expression
from programs.errors import ProgramSyntaxError
from programs.frames import quaternion_matrix, quaternions_like, transform
from programs.lexer import Cursor, Lexer, Token, undeclared
from programs.rapid_statements import (
    FRAME_SETTERS,
    INSTRUCTIONS,
    LAYOUTS,
    UNREAD_MOTIONS,
    Param,
    Split,
    params,
    path_end,
    split,
)
from programs.targets import (
    PROGRAM,
    Configuration,
    Frames,
    JointMove,
    Program,
    Target,
    target_at,
    unfollowed_call,
    written,
)

NAME = "rapid"
LEXER = Lexer(
    [
        ("newline", r"\r?\n"),
        ("blank", r"[ \t\f\v\r\ufeff]+"),
        ("comment", r"![^\r\n]*"),
        ("string", r'"(?:[^"\\\r\n]|\\.|"")*"'),
        ("number", r"(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?"),
        ("name", r"[A-Za-z_]\w*"),
        ("op", r":=|<>|<=|>=|[-+*/=<>()\[\]{},;:\\.%|]"),
    ],
    skip=frozenset({"blank", "comment", "newline"}),
)
STORAGE = frozenset({"const", "pers", "var"})
FRAME_TYPES = frozenset({"robtarget", "tooldata", "wobjdata", "jointtarget"})
"""The data this reader reads the values of: the targets and the frames they are taught in."""
SYSTEM_SUFFIX = ".sys"
"""System modules (user.sys, base.sys, a cell's tool and wobj declarations) are read for what they declare."""
DATA = "data, left alone: no motion of the program goes to it"
SYSTEM_DATA = "data, left alone: a system module (.sys), read for what it declares (tooldata, wobjdata)"
K = TypeVar("K")
MIN_DECIMALS = (3, 3, 3, 6, 6, 6, 6)
"""mm to 1 µm, quaternions to 1e-6 (2e-6 rad): the correction survives its printing."""


@dataclass(frozen=True)
class Agg:
    """A bracketed aggregate `[a, b, ...]`: its items, values or aggregates."""

    open: Token
    items: tuple[Agg | Value, ...]


def parse_aggregate(cur: Cursor) -> Agg:
    opening = cur.expect("op", "[")
    cur.enter(opening)
    items: list[Agg | Value] = []
    while True:
        items.append(_item(cur))
        if cur.accept("op", "]"):
            cur.leave()
            return Agg(opening, tuple(items))
        cur.expect("op", ",")


def _item(cur: Cursor) -> Agg | Value:
    tok = cur.peek()
    if tok is not None and tok.is_("op", "["):
        return parse_aggregate(cur)
    return literal_or_expression(cur, "]", "an aggregate item")


def statements(tokens: list[Token]) -> list[list[Token]]:
    """The token runs between `;` (a statement may span lines; `;` never stands inside a literal)."""
    out: list[list[Token]] = [[]]
    for tok in tokens:
        if tok.is_("op", ";"):
            out.append([])
        else:
            out[-1].append(tok)
    return [s for s in out if s]


def _numbers(agg: Agg | Value, n: int, cur: Cursor, what: str) -> list[Number | Opaque]:
    if not isinstance(agg, Agg) or len(agg.items) != n or any(isinstance(i, Agg) for i in agg.items):
        tok = agg.open if isinstance(agg, Agg) else agg.first
        raise cur.error(f"{what} has {n} values", tok)
    return [i for i in agg.items if not isinstance(i, Agg)]


def _pose(pos: list[Number | Opaque], quat: list[Number | Opaque]) -> Array | None:
    values = [*pos, *quat]
    if not all(isinstance(v, Number) for v in values):
        return None
    x = [v.value for v in values if isinstance(v, Number)]
    if not 1e-6 < math.hypot(*x[3:]) < 1e150:
        # A zero (or absurd) quaternion is no rotation: a pose of NaN, which the compensation lists as not a pose
        return np.full((4, 4), np.nan)
    return transform(x[:3], quaternion_matrix(x[3:]))


@dataclass(frozen=True)
class Robtarget:
    open: Token
    pose: Array | None
    numbers: tuple[Number | Opaque, ...]
    """x, y, z, q1, q2, q3, q4 as written."""
    configuration: Configuration | None


def robtarget(value: Agg | Value, cur: Cursor) -> Robtarget:
    """A robtarget's four parts, each of its size (a syntax error names the part that is not)."""
    if not isinstance(value, Agg) or len(value.items) != 4:
        tok = value.open if isinstance(value, Agg) else value.first
        raise cur.error("a robtarget has 4 parts: [[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a..eax_f]]", tok)
    pos = _numbers(value.items[0], 3, cur, "a robtarget's position")
    quat = _numbers(value.items[1], 4, cur, "a robtarget's orientation")
    conf = _numbers(value.items[2], 4, cur, "a robtarget's confdata")
    _numbers(value.items[3], 6, cur, "a robtarget's external axes")
    quarter = [int(c.value) for c in conf[:3] if isinstance(c, Number)]
    configuration = None
    if len(quarter) == 3:
        configuration = Configuration("quadrant", (0, 3, 5), tuple(quarter), "cf1, cf4, cf6 " + str(quarter))
    return Robtarget(value.open, _pose(pos, quat), (*pos, *quat), configuration)


def _joints(value: Agg | Value, line: int) -> JointMove | None:
    """A jointtarget's robot axes `[[j1..j6], [eax]]` (degrees) in radians; None unless six literal numbers."""
    if not isinstance(value, Agg) or not value.items or not isinstance(value.items[0], Agg):
        return None
    axes = [v.value for v in value.items[0].items if isinstance(v, Number)]
    if len(axes) != len(value.items[0].items) or not axes:
        return None
    return JointMove(tuple(math.radians(a) for a in axes), line)


def _frame_pose(value: Agg | Value, cur: Cursor, what: str) -> Array | None:
    """A `pose` [[x, y, z], [q1..q4]] (None where not literal numbers)."""
    if not isinstance(value, Agg) or len(value.items) != 2:
        raise cur.error(
            f"{what} is a pose [[x,y,z],[q1,q2,q3,q4]]", value.open if isinstance(value, Agg) else value.first
        )
    return _pose(_numbers(value.items[0], 3, cur, what + "'s position"), _numbers(value.items[1], 4, cur, what))


@dataclass(frozen=True)
class FrameData:
    matrix: Array | None
    kept: str | None


def tooldata(value: Agg | Value, cur: Cursor) -> FrameData:
    """[robhold, tframe, tload]: the TCP in the flange frame; a stationary tool (robhold FALSE) is kept."""
    if not isinstance(value, Agg) or len(value.items) != 3:
        raise cur.error("a tooldata is [robhold, tframe, tload]", value.open if isinstance(value, Agg) else value.first)
    hold = value.items[0]
    pose = _frame_pose(value.items[1], cur, "a tooldata's tframe")
    if isinstance(hold, Opaque) and hold.text.lower() == "false":
        return FrameData(pose, "a stationary tool (robhold FALSE): the robot carries the work object")
    return FrameData(pose, None if pose is not None else "the tool's tframe is not literal numbers")


def wobjdata(value: Agg | Value, cur: Cursor) -> FrameData:
    """[robhold, ufprog, ufmec, uframe, oframe]: the object frame in the robot's base, uframe · oframe."""
    if not isinstance(value, Agg) or len(value.items) != 5:
        tok = value.open if isinstance(value, Agg) else value.first
        raise cur.error("a wobjdata is [robhold, ufprog, ufmec, uframe, oframe]", tok)
    hold, _, mec = value.items[:3]
    uframe = _frame_pose(value.items[3], cur, "a wobjdata's uframe")
    oframe = _frame_pose(value.items[4], cur, "a wobjdata's oframe")
    pose = uframe @ oframe if uframe is not None and oframe is not None else None
    if isinstance(hold, Opaque) and hold.text.lower() == "true":
        return FrameData(pose, "a work object the robot holds (robhold TRUE): its base moves with the robot")
    if isinstance(mec, Opaque) and mec.text.strip('"'):
        return FrameData(pose, f"a user frame moved by the mechanical unit {mec.text}")
    return FrameData(pose, None if pose is not None else "the work object's frames are not literal numbers")


class Use(NamedTuple):
    """A motion to a named robtarget: its frames, why its target is kept, its line, the program displacement in
    force there and the warning of a routine's call before it (in the text's order)."""

    frames: Frames
    why: str | None
    line: int
    displaced: str | None
    warning: str | None


@dataclass
class Symbols:
    texts: Mapping[str | None, str] = field(default_factory=dict)
    types: dict[str, str] = field(default_factory=dict)
    robtargets: list[tuple[str | None, str, tuple[str, str | None], Robtarget]] = field(default_factory=list)
    """(file, name as written, (name, index), value) of every robtarget given a value."""
    frames: dict[str, FrameData] = field(default_factory=dict)
    arrays: set[str] = field(default_factory=set)
    given: dict[str, tuple[FrameData, str]] = field(default_factory=dict)
    """Per tooldata and wobjdata: its literal value and where it was given (`line 3`, `line 2 of cell.sys`)."""
    unknown: dict[str, str] = field(default_factory=dict)
    """Per tooldata and wobjdata the program changes other than by one literal value: why its frame is unknown."""
    robtarget_given: dict[tuple[str, str | None], tuple[Robtarget, str]] = field(default_factory=dict)
    """Per robtarget (array element): its first literal value and where it was given."""
    moved: dict[tuple[str, str | None], str] = field(default_factory=dict)
    """Per robtarget (an array's element, None: all of it, `*`: one the text does not say) the program changes
    other than by one literal value: why the point the robot goes to is known only at run time."""
    unread: dict[tuple[str, str | None], str] = field(default_factory=dict)
    """Robtargets named in a motion whose argument layout the reader does not know: why they are kept."""
    routines: dict[str, list[Param]] = field(default_factory=dict)
    """The routines (PROC, FUNC, TRAP) the sent modules define, by name, with their parameters."""
    writes: dict[str, set[str]] = field(default_factory=dict)
    """Per routine the names it assigns or passes to an instruction that writes them."""
    calls: list[tuple[str, str, list[Token], str | None]] = field(default_factory=list)
    """(caller, callee, statement, file) of every call of a routine in a routine."""
    unsent: dict[str, str] = field(default_factory=dict)
    """Per routine of the files: the routine not among the files it calls, itself or through the ones it calls."""
    routine: str | None = None
    displaced_routines: dict[str, tuple[str, int]] = field(default_factory=dict)
    """Routines of the files called (in the text's order) under a program displacement, or called by such a
    routine: their motions are displaced too, from their start."""
    displaced: tuple[str, int] | None = None
    """The PDispOn or PDispSet in force in the text's order within a routine, or the one the routine is called
    under (the instruction as written, its line)."""
    unfollowed: tuple[str, int] | None = None
    """The last call, in the routine being read, of a routine not among the files (its name, its line)."""
    uses: dict[tuple[str, str | None], list[Use]] = field(default_factory=dict)
    inline: list[tuple[str | None, Robtarget, Frames, str | None]] = field(default_factory=list)
    inline_warnings: list[str | None] = field(default_factory=list)
    jointtargets: dict[str, JointMove] = field(default_factory=dict)
    last_joints: JointMove | None = None
    after: dict[tuple[str, str | None], JointMove | None] = field(default_factory=dict)
    conf_off: dict[str, bool] = field(default_factory=lambda: {"movel": False, "movej": False})
    """ConfL \\Off, ConfJ \\Off in force (in the text's order): the controller does not hold the robtarget's cf."""
    held: set[tuple[str, str | None]] = field(default_factory=set)
    """Robtargets some motion goes to with their configuration held (Conf On)."""
    inline_after: list[tuple[JointMove | None, bool]] = field(default_factory=list)
    relative: dict[tuple[str, str | None], tuple[str, int]] = field(default_factory=dict)
    """Robtargets a motion reaches only through a function of them (Offs, RelTool): the function, its line."""
    motions: int = 0


def _index(cur: Cursor) -> str | None:
    if not cur.accept("op", "{"):
        return None
    parts, literal = [], True
    while not (tok := cur.next()).is_("op", "}"):
        literal &= tok.kind == "number" or tok.is_("op", ",")
        parts.append(tok.text)
    return "".join(parts) if literal else "*"


def _declaration(cur: Cursor, sym: Symbols, file: str | None) -> None:
    while (tok := cur.peek()) is not None and tok.text.lower() in ("local", "task"):
        cur.next()
    cur.expect("name")  # CONST, PERS or VAR
    type_name = cur.expect("name").text.lower()
    name = cur.expect("name")
    index = _index(cur)
    sym.types[name.text.lower()] = type_name
    if index is not None:
        sym.arrays.add(name.text.lower())
    if type_name not in FRAME_TYPES:
        return  # a num, a speeddata, a loaddata...: not read (its syntax is the controller's business)
    if cur.accept("op", ":="):
        value = _item(cur)
        _given(sym, file, cur, type_name, name, array=index is not None, value=value)
    if cur.peek() is not None:
        raise cur.error(f"unexpected {cur.peek().text!r} after the declaration", cur.peek())  # type: ignore[union-attr]


def _given(
    sym: Symbols, file: str | None, cur: Cursor, type_name: str, name: Token, *, array: bool, value: Agg | Value
) -> None:
    """A value given to a robtarget (each element of an array), a tooldata or a wobjdata."""
    key = name.text.lower()
    if type_name == "robtarget":
        elements = value.items if array and isinstance(value, Agg) else (value,)
        for k, element in enumerate(elements, start=1):
            index = str(k) if array else None
            written_name = name.text + (f"{{{k}}}" if array else "")
            _robtarget_given(sym, file, written_name, (key, index), robtarget(element, cur))
    elif type_name in ("tooldata", "wobjdata"):
        _frame_given(
            sym, name.text, (tooldata if type_name == "tooldata" else wobjdata)(value, cur), _where(file, name)
        )
    elif type_name == "jointtarget" and not array:
        found = _joints(value, name.line)
        if found is not None:
            sym.jointtargets[key] = found


def _arguments(tokens: list[Token]) -> tuple[list[list[Token]], dict[str, list[Token]]]:
    """A motion's positional arguments and its optional ones (`\\WObj:=wobj1`, which need no comma)."""
    positional: list[list[Token]] = [[]]
    optional: dict[str, list[Token]] = {}
    current = positional[-1]
    depth, k = 0, 0
    while k < len(tokens):
        tok = tokens[k]
        if depth == 0 and tok.is_("op", ","):
            positional.append([])
            current = positional[-1]
        elif depth == 0 and tok.is_("op", "\\") and k + 1 < len(tokens):
            current = optional.setdefault(tokens[k + 1].text.lower(), [])
            k += 2 + (k + 2 < len(tokens) and tokens[k + 2].is_("op", ":="))
            continue
        else:
            depth += tok.kind == "op" and tok.text in "([{"
            depth -= tok.kind == "op" and tok.text in ")]}"
            current.append(tok)
        k += 1
    return [p for p in positional if p], optional


def _where(file: str | None, tok: Token) -> str:
    return f"line {tok.line}" + (f" of {file}" if file is not None else "")


def _quote(sym: Symbols, file: str | None, body: list[Token]) -> str:
    """The statement as written (its spaces collapsed, cut at 80 characters), for a reason naming it."""
    text = " ".join(sym.texts.get(file, "")[body[0].start : body[-1].end].split()) + ";"
    return text if len(text) <= 80 else text[:77] + "...;"


def _frame_given(sym: Symbols, name: str, data: FrameData, where: str) -> None:
    """A literal value given to a tooldata or wobjdata; a second, different one leaves its frame unknown (which
    one a motion uses depends on the order the controller runs them). The same value twice is one value."""
    key = name.lower()
    before = sym.given.get(key)
    sym.frames[key] = data
    if before is None:
        sym.given[key] = (data, where)
        return
    old, old_where = before
    if old.kept != data.kept or not _same(old.matrix, data.matrix):
        _second_value(sym.unknown, key, f"{sym.types.get(key, 'the frame')} {name}", old_where, where)


def _robtarget_given(
    sym: Symbols, file: str | None, written_name: str, key: tuple[str, str | None], rt: Robtarget
) -> None:
    """A literal value given to a robtarget (or an array's element); a second, different one leaves the point
    the robot goes to unknown, as for a frame."""
    sym.robtargets.append((file, written_name, key, rt))
    where = _where(file, rt.open)
    old, old_where = sym.robtarget_given.setdefault(key, (rt, where))
    same_conf = (old.configuration and old.configuration.values) == (rt.configuration and rt.configuration.values)
    if old is not rt and not (same_conf and _same(old.pose, rt.pose) and (old.pose is not None or old == rt)):
        _second_value(sym.moved, key, f"robtarget {written_name}", old_where, where)


def _same(a: Array | None, b: Array | None) -> bool:
    """The same literal value (`0` and `0.0`, within 1e-9 mm)."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, atol=1e-9, equal_nan=True))


def _second_value(found: dict[K, str], key: K, what: str, before: str, where: str) -> None:
    found.setdefault(
        key,
        f"{what} is given two different values ({before} and {where}): which one the controller uses when it "
        "moves depends on the order it runs them, so the target is kept as written",
    )


def _changed(
    sym: Symbols, name: str, file: str | None, body: list[Token], how: str = "", *, index: str | None = None
) -> None:
    """A tooldata or wobjdata changed at run time other than by a literal: its frame is known only then; a
    robtarget (or an array's element, `index`) so changed: the point the robot goes to is known only then."""
    key = name.lower()
    point = sym.types.get(key) == "robtarget"
    shown = name + (f"{{{index}}}" if index not in (None, "*") else "")
    why = (
        f"{sym.types.get(key, 'the frame')} {shown} is changed at run time by `{_quote(sym, file, body)}` "
        f"({_where(file, body[0])}){how}: "
        f"{'the point the robot goes to' if point else 'the frame the controller moves in'} is known only then, "
        "so the target is kept as written"
    )
    if point:
        sym.moved.setdefault((key, index), why)
    else:
        sym.unknown.setdefault(key, why)


def _written(sym: Symbols, arg: list[Token], file: str | None, body: list[Token]) -> None:
    """A datum an instruction writes (an INOUT argument): noted for the routine writing it (a parameter it
    writes changes what its callers pass), and a robtarget, tooldata or wobjdata so changed at run time."""
    if not arg or arg[0].kind != "name" or (len(arg) > 1 and not arg[1].is_("op", "{")):
        return
    name, index = _named(arg, file)
    if sym.routine is not None:
        sym.writes.setdefault(sym.routine, set()).add(name)
    if _tracked(sym, name):
        _changed(sym, arg[0].text, file, body, index=index)


def _named(arg: list[Token], file: str | None) -> tuple[str, str | None]:
    """A datum named in an argument, `p10` or `path{2}`: its name and index (`*` where not a literal)."""
    ref = Cursor(arg, file, "the argument")
    ref.next()
    return arg[0].text.lower(), _index(ref)


def _frame(sym: Symbols, tokens: list[Token], default: str, file: str | None) -> tuple[Array | None, str, str | None]:
    """A motion's tool or work object by its name: (matrix, name, kept-reason); UndeclaredFrame if unknown."""
    if not tokens:
        return (None if default == "tool0" else np.eye(4)), default, None
    name = tokens[0]
    word = name.text.lower()
    if len(tokens) == 1 and word in ("tool0", "wobj0"):
        return np.eye(4), name.text, None
    found = sym.frames.get(word) if len(tokens) == 1 else None
    unknown = sym.unknown.get(word) if len(tokens) == 1 else None
    if found is None and unknown is not None:
        return np.eye(4), name.text, unknown  # declared without a value and set at run time
    if found is None:
        what = "".join(t.text for t in tokens)
        raise undeclared(f"{what} is not a tooldata or wobjdata the program or its files declare", file, name)
    return found.matrix if found.matrix is not None else np.eye(4), name.text, unknown or found.kept


def _in_force(sym: Symbols, frames: Frames) -> tuple[str | None, str | None]:
    """The program displacement in force at a motion (its reason), and the warning of a call before it that may
    have set its tool or work object."""
    displaced = None
    if sym.displaced is not None:
        what, line = sym.displaced
        displaced = (
            f"under the program displacement of {what} (line {line}), in force until PDispOff: "
            "the controller moves the target by a displacement known only at run time, so it is kept as written"
        )
    named = [
        f"{kind} {name}"
        for kind, name in (("tooldata", frames.tool_name), ("wobjdata", frames.base_name))
        if name is not None and name.lower() not in ("tool0", "wobj0")
    ]
    if sym.unfollowed is None or not named:
        return displaced, None
    return displaced, unfollowed_call(sym.unfollowed[0], sym.unfollowed[1], " or the ".join(named), compensated="read")


def _motion(run: list[Token], sym: Symbols, file: str | None) -> None:
    """A motion: its targets taught in its tool and its work object (`\\WObj:=`), where its layout says."""
    word = run[0].text.lower()
    layout = LAYOUTS.get(word)
    positional, optional = _arguments(run[1:])
    if layout is None:
        _unread_motion(run, positional, optional, sym, file)
        return
    if len(positional) < layout.shape.count(",") + 1:
        cur = Cursor(run, file, f"the {run[0].text} instruction")
        raise cur.error(f"{run[0].text} takes {layout.shape} (then its optional arguments)", run[0])
    tool_arg = positional[layout.tool]
    declared = sym.types.get(tool_arg[0].text.lower(), "tooldata") if len(tool_arg) == 1 else ""
    if layout.tool < 0 and declared != "tooldata":
        # The argument taken for the tool is another datum: a version of the instruction the reader does not know
        _unread_motion(run, positional, optional, sym, file)
        return
    tool, tool_name, tool_kept = _frame(sym, tool_arg, "tool0", file)
    wobj, wobj_name, wobj_kept = _frame(sym, optional.get("wobj", []), "wobj0", file)
    frames = Frames(wobj if wobj is not None else np.eye(4), tool, wobj_name, tool_name)
    why = tool_kept or wobj_kept
    displaced, warning = _in_force(sym, frames)
    held = not sym.conf_off["movej" if layout.joint else "movel"]
    for k in layout.targets:
        arg = positional[k]
        _motion_target(arg, sym, file, Use(frames, why, arg[0].line, displaced, warning), held=held)
    sym.motions += 1


def _motion_target(arg: list[Token], sym: Symbols, file: str | None, use: Use, *, held: bool) -> None:
    """A robtarget a motion goes to: written in it, named (`p10`, `path{2}`), or a function of one (Offs)."""
    if arg[0].is_("op", "["):
        inner = Cursor(arg, file, "the robtarget")
        sym.inline.append((file, robtarget(parse_aggregate(inner), inner), use.frames, use.why or use.displaced))
        sym.inline_after.append((sym.last_joints, held))
        sym.inline_warnings.append(use.warning)
    elif arg[0].kind == "name" and (len(arg) == 1 or arg[1].is_("op", "{")):
        key = _named(arg, file)
        sym.uses.setdefault(key, []).append(use)
        sym.after.setdefault(key, sym.last_joints)
        if held:
            sym.held.add(key)
    elif arg[0].kind == "name" and len(arg) > 3 and arg[1].is_("op", "(") and arg[2].kind == "name":
        # Offs(p10, ...), RelTool(...): a function of a target, computed by the controller at run time
        sym.relative.setdefault(_named(arg[2:], file), (arg[0].text, arg[0].line))


def _unread_motion(
    run: list[Token], positional: list[list[Token]], optional: dict[str, list[Token]], sym: Symbols, file: str | None
) -> None:
    """A motion whose argument layout the reader does not know: every robtarget it names or writes is kept
    (where its tool and work object are is not known, so no frame is guessed)."""
    why = (
        f"moved to by `{_quote(sym, file, run)}` ({_where(file, run[0])}), a motion the reader does not know the "
        "layout of: its tool and work object are not read, so the target is kept as written"
    )
    for arg in [*positional, *optional.values()]:
        if arg and arg[0].is_("op", "["):
            literal = _maybe_robtarget(arg, file)
            if literal is not None:
                sym.inline.append((file, literal, Frames(), why))
                sym.inline_after.append((sym.last_joints, True))
                sym.inline_warnings.append(None)
        elif arg and arg[0].kind == "name" and sym.types.get(arg[0].text.lower()) == "robtarget":
            sym.unread.setdefault(_named(arg, file), why)
    sym.motions += 1


def _maybe_robtarget(arg: list[Token], file: str | None) -> Robtarget | None:
    """An aggregate argument read as a robtarget, None where it is another datum (a speeddata written out)."""
    inner = Cursor(arg, file, "the robtarget")
    try:
        return robtarget(parse_aggregate(inner), inner)
    except ProgramSyntaxError:
        return None


def _written_by_motion(body: list[Token], sym: Symbols, file: str | None) -> None:
    """The robtargets a motion writes (SearchL's SearchPoint): changed at run time."""
    layout = LAYOUTS.get(body[0].text.lower())
    if layout is None or not layout.written:
        return
    positional, _ = _arguments(body[1:])
    for k in layout.written:
        if k < len(positional):
            _written(sym, positional[k], file, body)


def _joint_motion(run: list[Token], sym: Symbols) -> None:
    """`MoveAbsJ jt, ...` or `MoveAbsJ [[j1..j6],[eax]]\\NoEOffs, ...`: the joints the next targets start from."""
    positional, _ = _arguments(run[1:])
    if not positional:
        return
    arg = positional[0]
    if arg[0].is_("op", "["):
        cur = Cursor(arg, None, "the jointtarget")
        sym.last_joints = _joints(parse_aggregate(cur), arg[0].line)
    elif arg[0].kind == "name" and len(arg) == 1:
        sym.last_joints = sym.jointtargets.get(arg[0].text.lower())


def _kind(body: list[Token], sym: Symbols) -> str:
    """What a statement is: a declaration, a motion, an assignment, an instruction, a call (of a routine of the
    files, of one not among them, or late bound) or something the reader has no use for."""
    if body[0].is_("op", "%"):
        return "late"
    if body[0].kind != "name":
        return "other"
    word = body[0].text.lower()
    if word in STORAGE or word in ("local", "task"):
        return "declaration"
    if word in LAYOUTS or word in UNREAD_MOTIONS:
        return "motion"
    if word in ("confl", "confj", "moveabsj", "pdispon", "pdispset", "pdispoff", "callbyvar"):
        return word
    if path_end(body) is not None:
        return "assignment"
    if word in FRAME_SETTERS or word in ("setdataval", "setalldataval"):
        return "setter"
    if word in INSTRUCTIONS or (len(body) > 1 and body[1].is_("op", "(")):
        return "other"  # RAPID's own, or `f(...)` alone: no procedure call is written with parentheses
    return "routine" if word in sym.routines else "unsent"


def _declare(body: list[Token], sym: Symbols, file: str | None) -> None:
    """The declarations pass: data declared, literal values given, frames changed, routines' calls noted."""
    kind = _kind(body, sym)
    if kind == "declaration":
        _declaration(Cursor(body, file, "the statement"), sym, file)
    elif kind == "assignment":
        if sym.routine is not None:
            sym.writes.setdefault(sym.routine, set()).add(body[0].text.lower())
        _assignment(body, sym, file)
    elif kind == "setter":
        _setter(body, sym, file)
    elif kind == "motion":
        _written_by_motion(body, sym, file)
    elif kind in ("routine", "unsent", "late", "callbyvar") and sym.routine is not None:
        callee = body[0].text.lower() if kind == "routine" else _call_name(body, sym, file, kind)
        sym.calls.append((sym.routine, callee, body, file))
        if kind == "routine" and sym.displaced is not None:
            sym.displaced_routines.setdefault(callee, sym.displaced)
    elif kind in ("pdispon", "pdispset", "pdispoff"):
        sym.displaced = None if kind == "pdispoff" else (body[0].text, body[0].line)


def _walk(body: list[Token], sym: Symbols, file: str | None) -> None:
    """The motions pass, in the text's order: motions, Conf, MoveAbsJ, program displacement, calls."""
    kind = _kind(body, sym)
    word = body[0].text.lower()
    if kind == "motion":
        _motion(body, sym, file)
    elif kind in ("confl", "confj"):  # ConfL \Off: the controller takes the solution nearest the current joints
        sym.conf_off["movel" if word == "confl" else "movej"] = any(t.text.lower() == "off" for t in body[1:])
    elif kind == "moveabsj":
        _joint_motion(body, sym)
    elif kind in ("pdispon", "pdispset"):
        sym.displaced = (body[0].text, body[0].line)
    elif kind == "pdispoff":
        sym.displaced = None
    elif kind in ("unsent", "late", "callbyvar"):
        sym.unfollowed = (_call_name(body, sym, file, kind), body[0].line)
    elif kind == "routine" and word in sym.unsent:
        sym.unfollowed = (f"{sym.unsent[word]} (through {body[0].text})", body[0].line)


def _call_name(body: list[Token], sym: Symbols, file: str | None, kind: str) -> str:
    """A call's routine as written: its name, or the late-bound expression (`%"proc" + s%`, CallByVar)."""
    return body[0].text if kind == "unsent" else _quote(sym, file, body).rstrip(";")


def _assignment(body: list[Token], sym: Symbols, file: str | None) -> None:
    """`p10 := [...]`, `path{2} := [...]`: a literal given to declared data in a routine; a tooldata or wobjdata
    given anything else (a field, an expression, a function's value) is changed at run time."""
    cur = Cursor(body, file, "the statement")
    name = cur.next()
    type_name = sym.types.get(name.text.lower())
    if type_name in ("tooldata", "wobjdata"):
        _frame_assignment(body, sym, file)
        return
    index = _index(cur)
    point = type_name == "robtarget"
    if type_name not in FRAME_TYPES or not cur.accept("op", ":="):
        if point:  # a part of it: `p10.trans.z := p10.trans.z + 5;`
            _changed(sym, name.text, file, body, index=index)
        return
    nxt = cur.peek()
    if nxt is None or not nxt.is_("op", "["):
        if point:  # CRobT(...), Offs(p20, ...), another robtarget: the point is known at run time only
            _changed(sym, name.text, file, body, index=index)
        return
    value = _item(cur)
    if point and (index == "*" or cur.peek() is not None):
        _changed(sym, name.text, file, body, index=index)  # `path{i} := [...]`: the text does not say which one
    elif point and index is not None:
        written_name = f"{name.text}{{{index}}}"
        _robtarget_given(sym, file, written_name, (name.text.lower(), index), robtarget(value, cur))
    else:
        _given(sym, file, cur, type_name, name, array=name.text.lower() in sym.arrays, value=value)


def _frame_assignment(body: list[Token], sym: Symbols, file: str | None) -> None:
    name, at = body[0], path_end(body)
    if at is None:
        return
    if at > 1:
        if sym.types[name.text.lower()] == "tooldata" and body[1].is_("op", ".") and body[2].is_("name", "tload"):
            return  # the tool's load: where the TCP is does not change
        _changed(sym, name.text, file, body)
        return
    if at + 1 < len(body) and body[at + 1].is_("op", "[") and name.text.lower() not in sym.arrays:
        cur = Cursor(body, file, "the statement")
        cur.i = at + 1
        _given(sym, file, cur, sym.types[name.text.lower()], name, array=False, value=_item(cur))
        if cur.peek() is None:
            return
    _changed(sym, name.text, file, body)


def _setter(body: list[Token], sym: Symbols, file: str | None) -> None:
    """`MToolTCPCalib p1, p2, p3, p4, tool1, max, mean;` and the other instructions that write an argument,
    `SetDataVal "wobj1", w;` (the datum named by a string), `SetAllDataVal "tooldata", ...` (every one)."""
    word = body[0].text.lower()
    positional, optional = _arguments(body[1:])
    args = [*positional, *optional.values()]
    if word in ("setdataval", "setalldataval"):
        first = positional[0] if positional else []
        named = first[0].text.strip('"') if len(first) == 1 and first[0].kind == "string" else ""
        names = [n for n, t in sym.types.items() if t == named.lower()] if word == "setalldataval" else [named]
        for name in names:
            if _tracked(sym, name.lower()):
                _changed(sym, name, file, body)
        return
    for arg in args:
        _written(sym, arg, file, body)


def _follow_calls(sym: Symbols) -> None:
    """After the declarations pass: a call of a routine of the files that writes one of its INOUT, VAR or PERS
    parameters changes the tooldata or wobjdata passed there; and which routines call, themselves or through
    others, a routine not among the files (their calls are warned as its call is)."""
    for _, callee, body, file in sym.calls:
        if callee not in sym.routines:
            continue
        positional, optional = _arguments(body[1:])
        declared = sym.routines[callee]
        pairs = list(zip([p for p in declared if not p.optional], positional, strict=False))
        pairs += [(p, optional[p.name]) for p in declared if p.optional and p.name in optional]
        for param, arg in pairs:
            named = arg[0].kind == "name" and (len(arg) == 1 or arg[1].is_("op", "{"))
            key, index = _named(arg, file) if named else ("", None)
            if param.writable and param.name in sym.writes.get(callee, ()) and _tracked(sym, key):
                how = f", where {body[0].text} writes its parameter {param.name}"
                _changed(sym, arg[0].text, file, body, how, index=index)
    changed = True
    while changed:
        changed = False
        for caller, callee, _, _ in sym.calls:
            found = sym.unsent.get(callee) if callee in sym.routines else callee
            if found is not None and caller not in sym.unsent:
                sym.unsent[caller] = found
                changed = True
            displaced = sym.displaced_routines.get(caller)
            if displaced is not None and callee in sym.routines and callee not in sym.displaced_routines:
                sym.displaced_routines[callee] = displaced
                changed = True


def _is_frame(sym: Symbols, key: str) -> bool:
    return sym.types.get(key) in ("tooldata", "wobjdata")


def _tracked(sym: Symbols, key: str) -> bool:
    """A datum whose change at run time keeps targets: a robtarget, a tooldata, a wobjdata."""
    return sym.types.get(key) in ("tooldata", "wobjdata", "robtarget")


def _frames_of(sym: Symbols, key: tuple[str, str | None]) -> tuple[Frames, str | None, str | None]:
    """A named robtarget's frames, why it is kept and its warning, from the motions that go to it."""
    uses = sym.uses.get(key, []) + (sym.uses.get((key[0], "*"), []) if key[1] is not None else [])
    if not uses:
        return Frames(), None, None
    first = uses[0]
    warning = next((u.warning for u in uses if u.warning is not None), None)
    for use in uses[1:]:
        if use.frames.base_name != first.frames.base_name or use.frames.tool_name != first.frames.tool_name:
            return first.frames, f"used with different tools or work objects (lines {first.line} and {use.line})", None
    why = next((u.why for u in uses if u.why is not None), None)
    displaced = next((u for u in uses if u.displaced is not None), None)
    plain = next((u for u in uses if u.displaced is None), None)
    if why is None and displaced is not None:
        why = f"moved to at line {displaced.line} {displaced.displaced}"
        if plain is not None:
            # One value serves both motions: the correction of the plain one would move the displaced one too
            why += f"; also moved to without it (line {plain.line}), and its one value cannot carry both corrections"
    return first.frames, why, warning


def _held(rt: Robtarget, held: bool) -> Robtarget:
    """The robtarget with its configuration a hint only where no motion to it holds it (ConfL/ConfJ \\Off)."""
    if held or rt.configuration is None:
        return rt
    return replace(rt, configuration=replace(rt.configuration, enforced=False))


def _target(
    file: str | None,
    name: str | None,
    rt: Robtarget,
    frames: Frames,
    why: str | None,
    *,
    after: JointMove | None,
    warning: str | None = None,
) -> Target:
    literal = None if rt.pose is not None else "not literal numbers: the target is known only at run time"
    return target_at(
        file,
        name,
        rt.open,
        rt.numbers,
        rt.pose,
        frames=frames,
        kept=why or literal,
        configuration=rt.configuration,
        style="quaternion",
        after=after,
        warning=warning if why is None else None,
    )


def _passes(splits: list[tuple[str | None, Split]], sym: Symbols) -> None:
    """The declarations pass, then the motions pass, each over every file in the text's order. A routine's
    start ends the warning of a call (its body starts from what its caller set, and a call of it that matters
    is warned where it is called) and starts the program displacement it is called under (none if it is never
    called under one)."""
    for declarations in (True, False):
        last: object = object()
        record = False
        for file, part in splits:
            if file != last:
                last, sym.displaced, sym.unfollowed, sym.routine = file, None, None, None
            if part.routine is not None:
                sym.routine, sym.unfollowed = part.routine.text.lower(), None
                sym.displaced = sym.displaced_routines.get(sym.routine)
            record = part.record if part.record is not None else record
            if record or not part.body:
                continue  # a RECORD's fields are no statements
            (_declare if declarations else _walk)(part.body, sym, file)
        if declarations:
            _follow_calls(sym)


def read(program: str, files: Mapping[str, str]) -> Program:
    """The robtargets of a module and of the modules in `files` (where its tools and work objects may be)."""
    texts: dict[str | None, str] = {PROGRAM: program}
    texts.update(files)
    splits = [(name, split(run)) for name, text in texts.items() for run in statements(LEXER.tokens(text, name))]
    sym = Symbols(texts=texts)
    sym.routines = {p.routine.text.lower(): params(p.params) for _, p in splits if p.routine is not None}
    for _, part in splits:
        _declared_type(part.body, sym)
    _passes(splits, sym)
    targets = []
    for file, written_name, key, rt in sym.robtargets:
        frames, why, warning = _frames_of(sym, key)
        why, used = _kept(sym, file, key, why)
        held = _held(rt, not used or key in sym.held or (key[0], "*") in sym.held)
        targets.append(_target(file, written_name, held, frames, why, after=sym.after.get(key), warning=warning))
    targets += [
        _target(file, None, _held(rt, held), frames, why, after=after, warning=warning)
        for (file, rt, frames, why), (after, held), warning in zip(
            sym.inline, sym.inline_after, sym.inline_warnings, strict=True
        )
    ]
    return Program(NAME, texts, tuple(sorted(targets, key=lambda t: (t.file or "", t.line, t.column))))


def _kept(sym: Symbols, file: str | None, key: tuple[str, str | None], why: str | None) -> tuple[str | None, bool]:
    """Why a robtarget is kept (None: it is compensated; `why` is its frames' reason) and whether a motion
    goes to it. Its value changed at run time, or a motion of an unknown layout, keep it before its frames."""
    near = (key, (key[0], None), (key[0], "*"))
    moved = next((sym.moved[k] for k in near if k in sym.moved), None)
    unread = next((sym.unread[k] for k in near if k in sym.unread), None)
    used = key in sym.uses or (key[1] is not None and (key[0], "*") in sym.uses) or unread is not None
    if file is not None and file.lower().endswith(SYSTEM_SUFFIX):
        return SYSTEM_DATA, used  # read for its tooldata and wobjdata, never for targets
    if not used and key in sym.relative:
        function, line = sym.relative[key]
        return (
            f"data, left alone: reached only through {function}(...) (line {line}), an offset the controller "
            "computes from it at run time"
        ), used
    if not used:
        return (DATA if sym.motions else why), used
    return moved or unread or why, used


def _declared_type(body: list[Token], sym: Symbols) -> None:
    """A declaration's type, known before any statement is read (a module may assign a tooldata that a module
    read after it declares)."""
    names = [t for t in body[:5] if t.kind == "name"]
    while names and names[0].text.lower() in ("local", "task"):
        names = names[1:]
    if len(names) >= 3 and names[0].text.lower() in STORAGE:
        sym.types[names[2].text.lower()] = names[1].text.lower()


def numbers(targets: Sequence[Target], poses: Array) -> list[list[str]]:
    like = np.array([t.style.get("quaternion", (1.0, 0.0, 0.0, 0.0)) for t in targets], dtype=float).reshape(-1, 4)
    values = np.hstack([poses[:, :3, 3], quaternions_like(poses[:, :3, :3], like)])
    return [written(v, t.slots, MIN_DECIMALS) for v, t in zip(values, targets, strict=True)]
