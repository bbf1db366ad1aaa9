"""KUKA KRL: the Cartesian targets of .src and .dat files.

KRL statements end at the line's end; `;` starts a comment; names are case-insensitive. A Cartesian value is an
aggregate `{X 1.5, Y 2, Z 3, A 0, B 90, C 0, S 'B010', T 35, E1 0}` (E6POS; POS without E1..E6; FRAME without S
and T), optionally typed (`{E6POS: X ...}`): X, Y, Z in mm, A, B, C in degrees with R = Rz(A)·Ry(B)·Rx(C). The
targets are the values of the POS, E6POS and FRAME variables (declared with or without DECL, GLOBAL, CONST,
arrays by element) and the Cartesian aggregates written inside motions (PTP, LIN, CIRC and the spline SPTP,
SLIN, SCIRC). Joint values (AXIS, E6AXIS, `{A1 0, ...}`) are never targets. The frames in which a target is
taught follow the program's statements in order: `$BASE = ...`, `$TOOL = ...`, `BAS(#BASE, n)`, `BAS(#TOOL, n)`
and `FDAT_ACT = FPn` (TOOL_NO, BASE_NO of the FDAT), with BASE_DATA[n] and TOOL_DATA[n] as the program or its
files ($config.dat) assign them; `$BASE` is taken relative to the robot's base ($WORLD = $ROBROOT).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from models._types import Array
from programs.aggregates import Number, Opaque, Value, literal_or_expression
from programs.errors import ProgramError
from programs.frames import abc_matrix, abcs_like, transform
from programs.lexer import Cursor, Lexer, Token, undeclared
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

NAME = "krl"
LEXER = Lexer(
    [
        ("newline", r"\r?\n"),
        ("blank", r"[ \t\f\v\r\ufeff]+"),
        ("comment", r";[^\r\n]*"),
        ("directive", r"&[^\r\n]*"),
        ("string", r'"[^"\r\n]*"'),
        ("bits", r"'[BbHh][0-9A-Fa-f]*'"),
        ("char", r"'[^'\r\n]'"),
        ("enum", r"#[A-Za-z_][\w$]*"),
        ("number", r"(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?"),
        ("name", r"\$?[A-Za-z_][\w$]*"),
        ("op", r"==|<>|<=|>=|[-+*/=<>{}()\[\],.:]"),
    ],
    skip=frozenset({"blank", "comment", "directive"}),
)
CARTESIAN_TYPES = frozenset({"pos", "e6pos", "frame"})
DECLARED_TYPES = CARTESIAN_TYPES | {"fdat", "axis", "e6axis"}
MOTIONS = frozenset({"ptp", "lin", "circ", "sptp", "slin", "scirc"})
RELATIVE = frozenset({"ptp_rel", "lin_rel", "circ_rel", "sptp_rel", "slin_rel", "scirc_rel"})
POSE_MEMBERS = ("x", "y", "z", "a", "b", "c")
JOINT_MEMBERS = frozenset({f"a{k}" for k in range(1, 7)})
FRAME_TABLES = {"base_data": "base", "tool_data": "tool"}
SYSTEM_FILES = frozenset({"$config.dat", "$machine.dat", "$robcor.dat", "$option.dat", "$custom.dat"})
"""The controller's own data lists (KRC/R1/System, KRC/Steu/Mada): read for what they declare (TOOL_DATA,
BASE_DATA, FRAME variables a program names as a base or tool), never for targets: their FRAME and POS values
are reference points, corrections and machine data, and compensating them would move every program's frames."""
SOURCE_SUFFIXES = (".src", ".sub")
NOT_ROUTINES = frozenset(
    {"if", "while", "until", "switch", "case", "for", "repeat", "loop", "return", "exit", "halt", "wait", "elseif"}
    | {"interrupt", "trigger", "brake", "resume", "goto", "pulse", "cwrite", "cread", "swrite", "sread", "cast_to"}
    | {"cast_from", "strclear", "strcopy", "strcomp", "strfind", "strlen", "strdecllen", "on_error_proceed"}
    | {"err_clear", "err_raise", "varstate", "ir_stopm", "ptp_rel", "lin_rel", "circ_rel"}
)
"""Statements written `NAME (`…`)` that are KRL's own (control flow, system functions): they set no frame."""
"""Companion files whose motions count as uses (the .src of a .dat sent as the program, the other .src of a
KRC/R1 folder): motions live in sources, data lists only declare."""
MIN_DECIMALS = (3, 3, 3, 4, 4, 4)
"""mm to 1 µm and degrees to 1e-4° (2 µm at a metre): the correction survives its printing."""


@dataclass(frozen=True)
class Aggregate:
    open: Token
    members: dict[str, Value]
    type_name: str | None


@dataclass(frozen=True)
class Assigned:
    """A value given to a variable (or an array element) by a declaration or an assignment."""

    file: str | None
    name: str
    """As written (case kept), with its index: `XP1`, `PARR[2]`."""
    key: tuple[str, str | None]
    aggregate: Aggregate


@dataclass
class State:
    base: tuple[Array, str | None] = field(default_factory=lambda: (np.eye(4), None))
    tool: tuple[Array | None, str | None] = (None, None)


@dataclass
class Symbols:
    types: dict[str, str] = field(default_factory=dict)
    values: list[Assigned] = field(default_factory=list)
    tables: dict[tuple[str, int], Aggregate] = field(default_factory=dict)

    def value(self, name: str, index: str | None) -> Aggregate | None:
        for a in reversed(self.values):
            if a.key == (name.lower(), index):
                return a.aggregate
        return None


def lines(tokens: list[Token]) -> list[list[Token]]:
    out: list[list[Token]] = [[]]
    for tok in tokens:
        if tok.kind == "newline":
            out.append([])
        else:
            out[-1].append(tok)
    return [line for line in out if line]


def parse_aggregate(cur: Cursor) -> Aggregate:
    """`{ [TYPE:] name value, ... }` (values may be aggregates); a value that is not one literal is Opaque."""
    opening = cur.expect("op", "{")
    cur.enter(opening)
    type_name = None
    if cur.peek(1) is not None and cur.peek(1).is_("op", ":"):  # type: ignore[union-attr]
        type_name = cur.expect("name").text.lower()
        cur.next()
    members: dict[str, Value] = {}
    while not cur.accept("op", "}"):
        if members:
            cur.expect("op", ",")
        member = cur.expect("name")
        if cur.accept("op", "["):  # `POINT2[] " "`: an array member written whole
            cur.expect("op", "]")
        key = member.text.lower()
        if key in members:
            raise cur.error(f"member {member.text} is given twice", member)
        members[key] = _member_value(cur)
    cur.leave()
    return Aggregate(opening, members, type_name)


def _member_value(cur: Cursor) -> Value:
    tok = cur.peek()
    if tok is not None and tok.is_("op", "{"):
        inner = parse_aggregate(cur)
        return Opaque(inner.open, "{...}")
    return literal_or_expression(cur, "}", "a member's value")


@dataclass(frozen=True)
class Ref:
    name: Token
    index: str | None
    """The literal index (`2`, `1,3`), `*` for one computed at run time, None for a whole variable."""


@dataclass(frozen=True)
class Statement:
    kind: str
    """"decl", "assign", "motion", "bas", "def" (a routine's header: `first` is its name) or "call"."""
    first: Token
    type_name: str | None = None
    items: tuple[tuple[Ref, Aggregate | Ref | None], ...] = ()
    """decl: each declared name and its value; assign: the one target and its value; motion: (operand, None)."""
    relative: bool = False


def _index(cur: Cursor) -> str | None:
    if not cur.accept("op", "["):
        return None
    parts: list[str] = []
    literal = True
    depth = 0
    while True:
        tok = cur.next()
        if tok.is_("op", "]") and depth == 0:
            break
        depth += tok.is_("op", "[")
        depth -= tok.is_("op", "]")
        literal &= tok.kind == "number" or tok.is_("op", ",")
        parts.append(tok.text)
    return "".join(parts) if literal else "*"


def _operand(cur: Cursor) -> Aggregate | Ref | None:
    tok = cur.peek()
    if tok is None:
        return None
    if tok.is_("op", "{"):
        return parse_aggregate(cur)
    if tok.kind == "name":
        cur.next()
        return Ref(tok, _index(cur))
    return None


def statement(line: list[Token], file: str | None) -> Statement | None:
    """The statement of one line, where it can concern a target or a frame (None: any other)."""
    cur = Cursor(line, file, "the statement")
    head = line[0].text.lower()
    routine = _routine_header(line)
    if routine is not None:
        return Statement("def", routine)
    if line[0].kind == "name" and len(line) > 1 and line[1].is_("op", "(") and head not in MOTIONS and head != "bas":
        return Statement("call", line[0])
    if head in ("decl", "global", "const") or (head in DECLARED_TYPES and len(line) > 1 and line[1].kind == "name"):
        return _declaration(cur)
    if head in MOTIONS or head in RELATIVE:
        cur.next()
        operands = []
        while (operand := _operand(cur)) is not None:
            operands.append((Ref(line[0], None), operand))
            if not cur.accept("op", ","):
                break
        return Statement("motion", line[0], items=tuple(operands), relative=head in RELATIVE)
    if head == "bas" and len(line) >= 6 and line[2].kind == "enum":
        return Statement("bas", line[0], type_name=line[2].text.lower(), items=((Ref(line[4], None), None),))
    if line[0].kind == "name":
        target = Ref(cur.next(), _index(cur))
        if cur.accept("op", "="):
            value = _operand(cur)
            # `$BASE = BASE_DATA[1] : {X 10}`: an expression, not one value this reader can name
            return Statement("assign", line[0], items=((target, value if cur.peek() is None else None),))
    return None


def _routine_header(line: list[Token]) -> Token | None:
    """The name of `DEF name(`, `GLOBAL DEF name(` (a routine's first line); None for any other line."""
    words = [t.text.lower() for t in line[:3]]
    at = 1 if words[:1] == ["def"] else (2 if words[:2] == ["global", "def"] else None)
    if at is None or len(line) <= at or line[at].kind != "name":
        return None
    return line[at]


def _declaration(cur: Cursor) -> Statement | None:
    while (tok := cur.peek()) is not None and tok.text.lower() in ("decl", "global", "const"):
        cur.next()
    type_tok = cur.expect("name")
    type_name = type_tok.text.lower()
    if type_name not in DECLARED_TYPES:
        return None  # INT, REAL, PDAT, a structure's own type...
    items: list[tuple[Ref, Aggregate | Ref | None]] = []
    while True:
        name = cur.expect("name")
        ref = Ref(name, _index(cur))
        value: Aggregate | Ref | None = None
        if cur.accept("op", "="):
            value = _operand(cur)
            if value is None:
                raise cur.error(f"{name.text}'s value is not an aggregate or a name", cur.peek() or name)
        items.append((ref, value))
        if not cur.accept("op", ","):
            break
    if cur.peek() is not None:
        raise cur.error(f"unexpected {cur.peek().text!r} after the declaration", cur.peek())  # type: ignore[union-attr]
    return Statement("decl", type_tok, type_name=type_name, items=tuple(items))


def _statements(text: str, file: str | None) -> list[tuple[str | None, Statement]]:
    out = []
    for line in lines(LEXER.tokens(text, file)):
        found = statement(line, file)
        if found is not None:
            out.append((file, found))
    return out


def _symbols(statements: list[tuple[str | None, Statement]]) -> Symbols:
    """Every variable's type, every aggregate given to a variable, and the BASE_DATA / TOOL_DATA tables."""
    sym = Symbols()
    for _, st in statements:
        if st.kind == "decl" and st.type_name is not None:
            for ref, _ in st.items:
                sym.types[ref.name.text.lower()] = st.type_name
    for file, st in statements:
        if st.kind not in ("decl", "assign"):
            continue
        for ref, value in st.items:
            if not isinstance(value, Aggregate):
                continue
            name = ref.name.text.lower()
            if name in FRAME_TABLES and ref.index is not None and ref.index.isdigit():
                sym.tables[(FRAME_TABLES[name], int(ref.index))] = value
                continue
            written_name = ref.name.text + (f"[{ref.index}]" if ref.index is not None else "")
            sym.values.append(Assigned(file, written_name, (name, ref.index), value))
    return sym


def _is_cartesian(sym: Symbols, name: str, aggregate: Aggregate | None) -> bool:
    declared = sym.types.get(name.lower())
    if declared is not None:
        return declared in CARTESIAN_TYPES
    if aggregate is None:
        return False
    if aggregate.type_name is not None:
        return aggregate.type_name in CARTESIAN_TYPES
    keys = set(aggregate.members)
    return bool(keys & set(POSE_MEMBERS)) and not keys & JOINT_MEMBERS


def _pose(aggregate: Aggregate) -> tuple[Array | None, str | None]:
    """The transform of a Cartesian aggregate, or why it has none (a component omitted or not a number)."""
    missing = [m.upper() for m in POSE_MEMBERS if m not in aggregate.members]
    if missing:
        return None, (
            f"partial aggregate: {', '.join(missing)} omitted (the controller fills them in at run time); "
            "write the target whole to have it compensated"
        )
    values = [aggregate.members[m] for m in POSE_MEMBERS]
    opaque = [m.upper() for m, v in zip(POSE_MEMBERS, values, strict=True) if not isinstance(v, Number)]
    if opaque:
        return None, f"{', '.join(opaque)} not literal numbers: the value is known only at run time"
    x, y, z, a, b, c = (v.value for v in values if isinstance(v, Number))
    return transform([x, y, z], abc_matrix(a, b, c)), None


def _frame(sym: Symbols, value: Aggregate | Ref | None, st: Statement, file: str | None) -> tuple[Array, str]:
    """A base or tool frame named by `$BASE = ...` or found in a table; UndeclaredFrame where it is not."""
    line, column = st.first.line, st.first.column
    if value is None:
        raise ProgramError(
            "the frame is an expression this reader does not evaluate",
            reason="frame-expression",
            file=file,
            line=line,
            column=column,
        )
    if isinstance(value, Aggregate):
        pose, why = _pose(value)
        if pose is None:
            raise ProgramError(
                f"the frame cannot be read: {why}", reason="frame-partial", file=file, line=line, column=column
            )
        return pose, "{...}"
    name = value.name.text.lower()
    if name == "$nullframe":
        return np.eye(4), "$NULLFRAME"
    if name in FRAME_TABLES and value.index is not None and value.index.isdigit():
        return _table(sym, FRAME_TABLES[name], int(value.index), st, file)
    found = sym.value(name, value.index)
    if found is None:
        raise undeclared(
            f"{value.name.text} is not declared with a value in the program or its files", file, value.name
        )
    return _frame(sym, found, st, file)


def _table(sym: Symbols, kind: str, n: int, st: Statement, file: str | None) -> tuple[Array, str]:
    label = f"{kind.upper()}_DATA[{n}]"
    if n == 0:
        return np.eye(4), label  # number 0: the robot's base, the flange
    agg = sym.tables.get((kind, n))
    if agg is None:
        raise undeclared(
            f"{label} is used but neither the program nor its files ($config.dat) assign it", file, st.first
        )
    pose, why = _pose(agg)
    if pose is None:
        raise ProgramError(f"{label} cannot be read: {why}", reason="frame-partial", file=file, line=st.first.line)
    return pose, label


def _number_member(agg: Aggregate, key: str) -> int | None:
    v = agg.members.get(key)
    return int(v.value) if isinstance(v, Number) else None


def _fdat(sym: Symbols, state: State, value: Aggregate | Ref | None, st: Statement, file: str | None) -> str | None:
    """`FDAT_ACT = FPn`: the tool and base numbers of the FDAT; a kept-reason for an external TCP."""
    agg = sym.value(value.name.text.lower(), value.index) if isinstance(value, Ref) else value
    if agg is None:
        return None
    tool_no, base_no = _number_member(agg, "tool_no"), _number_member(agg, "base_no")
    if tool_no is not None:
        state.tool = _table(sym, "tool", tool_no, st, file)
    if base_no is not None:
        state.base = _table(sym, "base", base_no, st, file)
    ipo = agg.members.get("ipo_frame")
    if isinstance(ipo, Opaque) and ipo.text.lower() == "#tcp":
        return "an external (stationary) TCP, IPO_FRAME #TCP: the robot carries the part, not the tool"
    return None


@dataclass
class Walk:
    """What the program's statements, in order, say of each target: the frames of each use."""

    uses: dict[tuple[str, str | None], list[tuple[Frames, int, str | None]]] = field(default_factory=dict)
    inline: list[tuple[str | None, Aggregate, Frames, str | None]] = field(default_factory=list)
    frame_names: set[str] = field(default_factory=set)
    """Variables used as a base or a tool: frames, not targets."""
    motions: int = 0
    routines: dict[str, list[tuple[str | None, Statement]]] = field(default_factory=dict)
    last_joints: JointMove | None = None
    after: dict[tuple[str, str | None], JointMove | None] = field(default_factory=dict)
    """Per variable: the last joint move before its first motion."""
    inline_after: list[tuple[JointMove | None, bool]] = field(default_factory=list)
    """Per inline aggregate: the last joint move before it, and whether its motion is a PTP."""
    ptp: set[tuple[str, str | None]] = field(default_factory=set)
    """Variables some PTP goes to: the controller holds their S and T."""
    defined: set[str] = field(default_factory=set)
    """The routines (DEF) among the program's sources, whether they set frames or not."""
    unfollowed: dict[str, tuple[str, int]] = field(default_factory=dict)
    """In the file being walked: per frame ("base", "tool") the last call of a routine not among the files since
    that frame was last set (its name and line)."""
    warnings: dict[tuple[str, str | None], str] = field(default_factory=dict)
    """Per variable: the warning of its first motion after such a call."""
    inline_warnings: list[str | None] = field(default_factory=list)


def system_file(name: str | None) -> bool:
    return name is not None and name.replace("\\", "/").rsplit("/", 1)[-1].lower() in SYSTEM_FILES


def _walk(sym: Symbols, statements: list[tuple[str | None, Statement]], program: str | None) -> Walk:
    """The motions of the program and of the sources among its files (each source from its start: the frames
    are followed in each file's own order)."""
    walk = Walk()
    sources = [program, *sorted({f for f, _ in statements if f is not None and f.lower().endswith(SOURCE_SUFFIXES)})]
    walk.routines = _routines([(f, st) for f, st in statements if f in sources])
    walk.defined = {st.first.text.lower() for f, st in statements if f in sources and st.kind == "def"}
    for source in sources:
        _walk_file(sym, [(f, st) for f, st in statements if f == source], walk)
    return walk


def _walk_file(sym: Symbols, statements: list[tuple[str | None, Statement]], walk: Walk) -> None:
    state, kept = State(), None
    walk.unfollowed = {}
    for file, st in statements:
        if st.kind == "motion":
            _motion(st, file, Frames(state.base[0], state.tool[0], state.base[1], state.tool[1]), kept, walk)
            joints = None if st.relative else _joint_move(sym, st)
            if joints is not None:
                walk.last_joints = joints
        elif st.kind == "call":
            name = st.first.text.lower()
            if name in walk.defined:
                # A literal call of a routine among the files: the frames it sets hold after it, as on the controller
                for routine_file, inner in walk.routines.get(name, ()):
                    kept = _frame_statement(sym, inner, routine_file, state, walk, kept=kept)
            elif name not in NOT_ROUTINES:
                # Its body was not sent: it may set $BASE or $TOOL (a global system variable) for what follows.
                walk.unfollowed = dict.fromkeys(("base", "tool"), (st.first.text, st.first.line))
        elif st.kind == "def":
            walk.unfollowed = {}  # a routine's own body starts from what its caller set, followed where called
        else:
            kept = _frame_statement(sym, st, file, state, walk, kept=kept)
            _settled(st, walk)


def _settled(st: Statement, walk: Walk) -> None:
    """A frame set after a call not followed is known again from here."""
    if st.kind == "assign" and st.items[0][0].name.text.lower() in ("$base", "$tool"):
        walk.unfollowed.pop(st.items[0][0].name.text.lower()[1:], None)
    elif st.kind == "assign" and st.items[0][0].name.text.lower() == "fdat_act":
        walk.unfollowed = {}
    elif st.kind == "bas" and st.type_name in ("#tool", "#base"):
        walk.unfollowed.pop(st.type_name[1:], None)


def _unfollowed_warning(walk: Walk) -> str | None:
    if not walk.unfollowed:
        return None
    (name, line), frames = next(iter(walk.unfollowed.values())), sorted(walk.unfollowed)
    return unfollowed_call(f"{name}( )", line, " or ".join(f"${f.upper()}" for f in frames))


def _frame_statement(
    sym: Symbols, st: Statement, file: str | None, state: State, walk: Walk, *, kept: str | None
) -> str | None:
    """`$BASE =`, `$TOOL =`, `BAS(#BASE|#TOOL, n)`, `FDAT_ACT =`: the state changed; the FDAT's kept-reason."""
    if st.kind == "assign":
        ref, value = st.items[0]
        name = ref.name.text.lower()
        if name in ("$base", "$tool"):
            setattr(state, name[1:], _frame(sym, value, st, file))
            if isinstance(value, Ref):
                walk.frame_names.add(value.name.text.lower())
        elif name == "fdat_act":
            return _fdat(sym, state, value, st, file)
    elif st.kind == "bas" and st.type_name in ("#tool", "#base"):
        number = st.items[0][0].name
        if number.kind == "number":
            setattr(state, st.type_name[1:], _table(sym, st.type_name[1:], _table_index(number, file), st, file))
    return kept


def _table_index(number: Token, file: str | None) -> int:
    """BAS's second argument as a TOOL_DATA / BASE_DATA index: BAS.SRC declares it REAL, so `BAS(#TOOL, 1.0)` is
    valid KRL (a fuzz found `0.0` answered a 500); a number that is not a whole index is refused, named."""
    try:
        value = float(number.text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value == int(value) and value >= 0):
        raise ProgramError(
            f"BAS's frame number {number.text} is not a whole table index",
            reason="frame-partial",
            file=file,
            line=number.line,
            column=number.column,
        )
    return int(value)


def _routines(statements: list[tuple[str | None, Statement]]) -> dict[str, list[tuple[str | None, Statement]]]:
    """Each routine's (DEF name ... END) statements that set frames, by its name: what a call of it applies."""
    out: dict[str, list[tuple[str | None, Statement]]] = {}
    current: list[tuple[str | None, Statement]] | None = None
    for file, st in statements:
        if st.kind == "def":
            current = out.setdefault(st.first.text.lower(), [])
        elif current is not None and st.kind in ("assign", "bas"):
            current.append((file, st))
    return {name: body for name, body in out.items() if body}


def _motion(st: Statement, file: str | None, frames: Frames, kept: str | None, walk: Walk) -> None:
    """A motion's operands: inline aggregates and the variables it names, with its frames and the last joint
    move before it (where the controller's solve starts)."""
    why = "a relative motion: its value is an offset, not a pose" if st.relative else kept
    # KUKA reads S and T on a PTP only; a LIN or CIRC keeps the configuration it starts in.
    point_to_point = st.first.text.lower() in ("ptp", "sptp")
    warning = _unfollowed_warning(walk)
    for _, operand in st.items:
        if isinstance(operand, Aggregate):
            walk.inline.append((file, operand, frames, why))
            walk.inline_after.append((walk.last_joints, point_to_point))
            walk.inline_warnings.append(warning)
        elif isinstance(operand, Ref):
            key = (operand.name.text.lower(), operand.index)
            if warning is not None:
                walk.warnings.setdefault(key, warning)
            walk.uses.setdefault(key, []).append((frames, st.first.line, why))
            walk.after.setdefault(key, walk.last_joints)
            if point_to_point:
                walk.ptp.add(key)
    walk.motions += 1


def _joint_move(sym: Symbols, st: Statement) -> JointMove | None:
    """The axes a PTP goes to, written inline (`{A1 0, A2 -90, ...}`) or as an AXIS/E6AXIS variable (XHOME)."""
    if not st.items or st.first.text.lower() not in ("ptp", "sptp"):
        return None
    operand = st.items[0][1]
    agg = operand if isinstance(operand, Aggregate) else None
    if isinstance(operand, Ref) and sym.types.get(operand.name.text.lower()) in ("axis", "e6axis"):
        agg = sym.value(operand.name.text.lower(), operand.index)
    if agg is None:
        return None
    values = [agg.members.get(f"a{k}") for k in range(1, 7)]
    numbers = [v.value for v in values if isinstance(v, Number)]
    if len(numbers) != len(values):
        return None
    return JointMove(tuple(float(np.radians(v)) for v in numbers), st.first.line)


def _frames_of(walk: Walk, key: tuple[str, str | None]) -> tuple[Frames, str | None]:
    """The one set of frames a variable is used with (a reason instead when its uses disagree)."""
    uses = walk.uses.get(key, []) + (walk.uses.get((key[0], "*"), []) if key[1] is not None else [])
    if not uses:
        return Frames(), None
    first = uses[0][0]
    for frames, line, _ in uses[1:]:
        same_tool = (frames.tool is None) == (first.tool is None) and (
            frames.tool is None or np.allclose(frames.tool, first.tool)  # type: ignore[arg-type]
        )
        if not (same_tool and np.allclose(frames.base, first.base)):
            return first, f"used with different bases or tools (lines {uses[0][1]} and {line})"
    return first, next((why for _, _, why in uses if why), None)


DATA = "data, left alone: no motion of the program goes to it"
SYSTEM_DATA = "data, left alone: the controller's system data, read for what it declares (TOOL_DATA, BASE_DATA)"
"""A Cartesian value no PTP/LIN/CIRC/SPLINE names (a measured point, a computed base, arithmetic): kept."""


def _used(walk: Walk, key: tuple[str, str | None]) -> bool:
    return key in walk.uses or (key[1] is not None and (key[0], "*") in walk.uses)


def _target(
    file: str | None,
    name: str | None,
    agg: Aggregate,
    frames: Frames,
    why: str | None,
    *,
    after: JointMove | None,
    held: bool = True,
    warning: str | None = None,
) -> Target:
    pose, partial = _pose(agg)
    turn = _turn(agg)
    if turn is not None and not held:
        turn = replace(turn, enforced=False)
    members = [agg.members.get(m) for m in POSE_MEMBERS]
    return target_at(
        file,
        name,
        agg.open,
        members,
        pose,
        frames=frames,
        kept=partial or why,
        configuration=turn,
        style="abc",
        after=after,
        warning=warning,
    )


def _turn(agg: Aggregate) -> Configuration | None:
    """T: bit k set where axis k+1 is negative (KUKA's turn); given as a number or as 'B010011'."""
    t = agg.members.get("t")
    if isinstance(t, Number):
        bits = int(t.value)
    elif isinstance(t, Opaque) and t.text[:2].upper() in ("'B", "'H"):
        bits = int(t.text[2:-1] or "0", 2 if t.text[1] in "Bb" else 16)
    else:
        return None
    return Configuration("sign", tuple(range(6)), tuple((bits >> k) & 1 for k in range(6)), f"T {t.text}")


def read(program: str, files: Mapping[str, str]) -> Program:
    """The Cartesian targets of a .src or .dat text and of its companion files (.dat, $config.dat)."""
    statements = [*_statements(program, PROGRAM)]
    for name, text in files.items():
        statements += _statements(text, name)
    sym = _symbols(statements)
    walk = _walk(sym, statements, PROGRAM)
    targets = []
    for assigned in sym.values:
        name = assigned.key[0]
        if name in walk.frame_names or not _is_cartesian(sym, name, assigned.aggregate):
            continue
        frames, why = _frames_of(walk, assigned.key)
        if system_file(assigned.file):
            why = SYSTEM_DATA
        elif walk.motions and not _used(walk, assigned.key):
            why = DATA
        elif not walk.motions and sym.types.get(name) == "frame":
            why = DATA  # a data list alone: its POS/E6POS are taught points, its FRAMEs are bases and tools
        after = walk.after.get(assigned.key) or walk.after.get((assigned.key[0], "*"))
        key = assigned.key
        held = not _used(walk, key) or key in walk.ptp or (key[0], "*") in walk.ptp
        warning = walk.warnings.get(key) or walk.warnings.get((key[0], "*"))
        targets.append(
            _target(
                assigned.file, assigned.name, assigned.aggregate, frames, why, after=after, held=held, warning=warning
            )
        )
    for (file, agg, frames, why), (after, ptp), warning in zip(
        walk.inline, walk.inline_after, walk.inline_warnings, strict=True
    ):
        if _is_cartesian(sym, "", agg):
            targets.append(_target(file, None, agg, frames, why, after=after, held=ptp, warning=warning))
    texts: dict[str | None, str] = {PROGRAM: program}
    texts.update(files)
    return Program(NAME, texts, tuple(sorted(targets, key=lambda t: (t.file or "", t.line, t.column))))


def numbers(targets: Sequence[Target], poses: Array) -> list[list[str]]:
    like = np.array([t.style.get("abc", (0.0, 0.0, 0.0)) for t in targets], dtype=float).reshape(-1, 3)
    values = np.hstack([poses[:, :3, 3], abcs_like(poses[:, :3, :3], like)])
    return [written(v, t.slots, MIN_DECIMALS) for v, t in zip(values, targets, strict=True)]


__all__ = ["NAME", "numbers", "read"]
