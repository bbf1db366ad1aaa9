"""ABB RAPID: the robtargets of .mod / .prg modules.

A robtarget is `[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], [eax_a, ..., eax_f]]`: the TCP in mm in the
work object's object frame, a unit quaternion with q1 the scalar, the configuration (quarter turns of axes 1,
4 and 6, and the arm's configuration number) and the external axes (9E9 where none). The targets are the
robtarget data (CONST, PERS or VAR; LOCAL or TASK; arrays `{n}` by element; values given with `:=` in a
declaration or an assignment) and the robtargets written inside motions (MoveL, MoveJ, MoveC and their DO,
Sync and AO variants). A motion's tool (`tooldata`, its tframe) and its work object (`\\WObj:=`, uframe ·
oframe of the `wobjdata`) are the frames it is taught in; `tool0` is the flange and `wobj0` the robot's base.
jointtargets, speeds, zones and every other datum are kept as written. `!` starts a comment; statements end
with `;` and may span lines.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from models._types import Array
from programs.aggregates import Number, Opaque, Value, literal_or_expression
from programs.frames import quaternion_matrix, quaternions_like, transform
from programs.lexer import Cursor, Lexer, Token, undeclared
from programs.targets import PROGRAM, Configuration, Frames, JointMove, Program, Target, target_at, written

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
MOTIONS = {
    name: points
    for points, names in (
        (1, ("movel", "movej", "moveldo", "movejdo", "movelsync", "movejsync", "movelao", "movejao")),
        (2, ("movec", "movecdo", "movecsync", "movecao")),
    )
    for name in names
}
"""Each motion's number of robtarget arguments; its tool is the positional argument two after them."""
SYSTEM_SUFFIX = ".sys"
"""System modules (user.sys, base.sys, a cell's tool and wobj declarations) are read for what they declare."""
DATA = "data, left alone: no motion of the program goes to it"
SYSTEM_DATA = "data, left alone: a system module (.sys), read for what it declares (tooldata, wobjdata)"
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


@dataclass
class Symbols:
    types: dict[str, str] = field(default_factory=dict)
    robtargets: list[tuple[str | None, str, tuple[str, str | None], Robtarget]] = field(default_factory=list)
    """(file, name as written, (name, index), value) of every robtarget given a value."""
    frames: dict[str, FrameData] = field(default_factory=dict)
    arrays: set[str] = field(default_factory=set)
    uses: dict[tuple[str, str | None], list[tuple[Frames, str | None, int]]] = field(default_factory=dict)
    inline: list[tuple[str | None, Robtarget, Frames, str | None]] = field(default_factory=list)
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


def _start(run: list[Token]) -> int:
    """Where the statement begins in a run: after a block's header (PROC main(), IF c THEN, MODULE m ...)."""
    for k, tok in enumerate(run):
        word = tok.text.lower()
        if tok.kind != "name":
            continue
        if word in ("local", "task"):
            # LOCAL PERS ...: a declaration; LOCAL PROC / FUNC / TRAP / RECORD: a block's header, skipped
            if k + 1 < len(run) and run[k + 1].text.lower() in (*STORAGE, "local", "task"):
                return k
            continue
        if word in STORAGE or word in MOTIONS or word in ("confl", "confj", "moveabsj"):
            return k
        if k + 1 < len(run) and (run[k + 1].is_("op", ":=") or run[k + 1].is_("op", "{")):
            return k
    return len(run)


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
            sym.robtargets.append((file, written_name, (key, index), robtarget(element, cur)))
    elif type_name == "tooldata":
        sym.frames[key] = tooldata(value, cur)
    elif type_name == "wobjdata":
        sym.frames[key] = wobjdata(value, cur)
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


def _frame(sym: Symbols, tokens: list[Token], default: str, file: str | None) -> tuple[Array | None, str, str | None]:
    """A motion's tool or work object by its name: (matrix, name, kept-reason); UndeclaredFrame if unknown."""
    if not tokens:
        return (None if default == "tool0" else np.eye(4)), default, None
    name = tokens[0]
    word = name.text.lower()
    if len(tokens) == 1 and word in ("tool0", "wobj0"):
        return np.eye(4), name.text, None
    found = sym.frames.get(word) if len(tokens) == 1 else None
    if found is None:
        what = "".join(t.text for t in tokens)
        raise undeclared(f"{what} is not a tooldata or wobjdata the program or its files declare", file, name)
    return found.matrix if found.matrix is not None else np.eye(4), name.text, found.kept


def _motion(run: list[Token], sym: Symbols, file: str | None) -> None:
    points = MOTIONS[run[0].text.lower()]
    positional, optional = _arguments(run[1:])
    cur = Cursor(run, file, f"the {run[0].text} instruction")
    if len(positional) < points + 3:
        raise cur.error(f"{run[0].text} needs {points} target(s), a speed, a zone and a tool", run[0])
    tool, tool_name, tool_kept = _frame(sym, positional[points + 2], "tool0", file)
    wobj, wobj_name, wobj_kept = _frame(sym, optional.get("wobj", []), "wobj0", file)
    frames = Frames(wobj if wobj is not None else np.eye(4), tool, wobj_name, tool_name)
    why = tool_kept or wobj_kept
    held = not sym.conf_off["movel" if run[0].text.lower().startswith(("movel", "movec")) else "movej"]
    for arg in positional[:points]:
        if arg[0].is_("op", "["):
            inner = Cursor(arg, file, "the robtarget")
            sym.inline.append((file, robtarget(parse_aggregate(inner), inner), frames, why))
            sym.inline_after.append((sym.last_joints, held))
        elif arg[0].kind == "name" and (len(arg) == 1 or arg[1].is_("op", "{")):
            ref = Cursor(arg, file, "the robtarget")
            ref.next()
            key = (arg[0].text.lower(), _index(ref))
            sym.uses.setdefault(key, []).append((frames, why, arg[0].line))
            sym.after.setdefault(key, sym.last_joints)
            if held:
                sym.held.add(key)
        elif arg[0].kind == "name" and len(arg) > 3 and arg[1].is_("op", "(") and arg[2].kind == "name":
            # Offs(p10, ...), RelTool(...): a function of a target, computed by the controller at run time
            inner = Cursor(arg[2:], file, "the robtarget")
            inner.next()
            key = (arg[2].text.lower(), _index(inner))
            sym.relative.setdefault(key, (arg[0].text, arg[0].line))
    sym.motions += 1


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


def _statement(run: list[Token], sym: Symbols, file: str | None, declarations: bool) -> None:
    run = run[_start(run) :]
    if not run:
        return
    word = run[0].text.lower()
    cur = Cursor(run, file, "the statement")
    if word in STORAGE or word in ("local", "task"):
        if declarations:
            _declaration(cur, sym, file)
    elif word in MOTIONS:
        if not declarations:
            _motion(run, sym, file)
    elif word in ("confl", "confj"):
        if not declarations:  # ConfL \Off: the controller takes the solution nearest the current joints
            sym.conf_off["movel" if word == "confl" else "movej"] = any(t.text.lower() == "off" for t in run[1:])
    elif word == "moveabsj":
        if not declarations:
            _joint_motion(run, sym)
    elif declarations:
        _assignment(cur, sym, file)


def _assignment(cur: Cursor, sym: Symbols, file: str | None) -> None:
    """`p10 := [...]`, `path{2} := [...]`: a literal given to declared data in a routine."""
    name = cur.next()
    index = _index(cur)
    type_name = sym.types.get(name.text.lower())
    if type_name not in FRAME_TYPES or not cur.accept("op", ":="):
        return
    nxt = cur.peek()
    if nxt is None or not nxt.is_("op", "["):
        return  # an expression: Offs(...), another variable
    value = _item(cur)
    if type_name == "robtarget" and index is not None:
        if index != "*":
            written_name = f"{name.text}{{{index}}}"
            sym.robtargets.append((file, written_name, (name.text.lower(), index), robtarget(value, cur)))
        return
    _given(sym, file, cur, type_name, name, array=name.text.lower() in sym.arrays, value=value)


def _frames_of(sym: Symbols, key: tuple[str, str | None]) -> tuple[Frames, str | None]:
    uses = sym.uses.get(key, []) + (sym.uses.get((key[0], "*"), []) if key[1] is not None else [])
    if not uses:
        return Frames(), None
    first, why, line = uses[0]
    for frames, other_why, other_line in uses[1:]:
        if frames.base_name != first.base_name or frames.tool_name != first.tool_name:
            return first, f"used with different tools or work objects (lines {line} and {other_line})"
        why = why or other_why
    return first, why


def _held(rt: Robtarget, held: bool) -> Robtarget:
    """The robtarget with its configuration a hint only where no motion to it holds it (ConfL/ConfJ \\Off)."""
    if held or rt.configuration is None:
        return rt
    return replace(rt, configuration=replace(rt.configuration, enforced=False))


def _target(
    file: str | None, name: str | None, rt: Robtarget, frames: Frames, why: str | None, *, after: JointMove | None
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
    )


def read(program: str, files: Mapping[str, str]) -> Program:
    """The robtargets of a module and of the modules in `files` (where its tools and work objects may be)."""
    texts: dict[str | None, str] = {PROGRAM: program}
    texts.update(files)
    runs = [(name, run) for name, text in texts.items() for run in statements(LEXER.tokens(text, name))]
    sym = Symbols()
    for declarations in (True, False):
        for name, run in runs:
            _statement(run, sym, name, declarations)
    targets = []
    for file, written_name, key, rt in sym.robtargets:
        frames, why = _frames_of(sym, key)
        used = key in sym.uses or (key[1] is not None and (key[0], "*") in sym.uses)
        if file is not None and file.lower().endswith(SYSTEM_SUFFIX):
            why = SYSTEM_DATA  # read for its tooldata and wobjdata, never for targets
        elif not used and key in sym.relative:
            function, line = sym.relative[key]
            why = (
                f"data, left alone: reached only through {function}(...) (line {line}), an offset the controller "
                "computes from it at run time"
            )
        elif not used and sym.motions:
            why = DATA
        held = _held(rt, not used or key in sym.held or (key[0], "*") in sym.held)
        targets.append(_target(file, written_name, held, frames, why, after=sym.after.get(key)))
    targets += [
        _target(file, None, _held(rt, held), frames, why, after=after)
        for (file, rt, frames, why), (after, held) in zip(sym.inline, sym.inline_after, strict=True)
    ]
    return Program(NAME, texts, tuple(sorted(targets, key=lambda t: (t.file or "", t.line, t.column))))


def numbers(targets: Sequence[Target], poses: Array) -> list[list[str]]:
    like = np.array([t.style.get("quaternion", (1.0, 0.0, 0.0, 0.0)) for t in targets], dtype=float).reshape(-1, 4)
    values = np.hstack([poses[:, :3, 3], quaternions_like(poses[:, :3, :3], like)])
    return [written(v, t.slots, MIN_DECIMALS) for v, t in zip(values, targets, strict=True)]
