"""Universal Robots URScript: the Cartesian targets of a .script program.

A pose is `p[x, y, z, rx, ry, rz]`: metres and a rotation vector (axis times angle, radians), in the robot's
base frame. The targets are the pose literals a motion goes to (movel, movej, movep, servoc; movec's via and
end poses), written as the motion's argument or given to a variable (`global Waypoint_1_p = p[...]`) that a
motion names, and those placed in a feature by `pose_trans(feature, p[...])`, where the feature's own literal
is the base. `set_tcp(p[...])` sets the tool of the motions after it (in the text's order); without one the
robot model's tool applies. Joint lists (`movej([...])`) and every other pose (offsets, features, the TCP) are
kept as written. `#` starts a comment.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from models._types import Array
from models.transforms import rotvec_to_matrix_np
from programs.aggregates import Number, Value, literal_or_expression, plain_number, signed_number
from programs.errors import UndeclaredFrame
from programs.frames import rotvec_matrix, rotvecs_like, transform
from programs.lexer import Cursor, Lexer, Token, undeclared
from programs.targets import PROGRAM, Frames, JointMove, Program, Target, target_at, unfollowed_call, written

NAME = "urscript"
LEXER = Lexer(
    [
        ("newline", r"\r?\n"),
        ("blank", r"[ \t\f\v\r\ufeff]+|\\\r?\n"),
        ("comment", r"#[^\r\n]*"),
        ("string", r'"(?:[^"\\\r\n]|\\.)*"' + r"|'(?:[^'\\\r\n]|\\.)*'"),
        ("number", r"(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?"),
        ("name", r"[A-Za-z_]\w*"),
        ("op", r"==|!=|<=|>=|[-+*/%=<>()\[\],:.{}$]"),
    ],
    skip=frozenset({"blank", "comment", "newline"}),
)
MOTIONS = {"movel": (0,), "movej": (0,), "movep": (0,), "servoc": (0,), "movec": (0, 1)}
"""Each motion's pose arguments (0-based)."""
DATA = "data, left alone: no motion of the program goes to it"
_IN_MOVED = (
    "placed by pose_trans in {0}, which the program also moves to and which is compensated itself: the two "
    "corrections would add up; left as written"
)
METRE_DECIMALS = (6, 6, 6, 6, 6, 6)
"""1 µm and 1e-6 rad (1 µm at a metre): the correction survives its printing."""


@dataclass(frozen=True)
class Pose:
    """A `p[...]` literal: its six values (metres, radians) and its tokens."""

    open: Token
    values: tuple[Value, ...]
    end: int
    """Index of the token after its `]`."""


@dataclass(eq=False)
class Context:
    """The call (or bracket) a token stands in: its name, which argument, and for `pose_trans` its feature."""

    name: str
    argument: int = 0
    feature: str | None = None


def parse_pose(cur: Cursor) -> Pose:
    plain = _plain_pose(cur)
    if plain is not None:
        return plain
    opening = cur.expect("name", "p")
    cur.expect("op", "[")
    values: list[Value] = []
    tokens = cur.tokens
    while True:
        values.append(plain_number(cur, "]") or _element(cur))
        closing = tokens[cur.i] if cur.i < len(tokens) else None
        if closing is not None and closing.kind == "op" and closing.text == "]":
            cur.i += 1
            break
        cur.expect("op", ",")
    if len(values) != 6:
        raise cur.error(f"a pose has 6 numbers (x, y, z, rx, ry, rz), this one has {len(values)}", opening)
    return Pose(opening, tuple(values), cur.i)


_SEPARATORS = (",", ",", ",", ",", ",", "]")


def _plain_pose(cur: Cursor) -> Pose | None:
    """The common pose, `p[` and six (signed) numbers `]`, read straight off the token list (the general
    reading costs about twenty method calls a pose); None otherwise, the cursor unmoved."""
    tokens, i = cur.tokens, cur.i
    if i + 14 > len(tokens):  # the shortest such pose: p [ and six numbers each with its separator
        return None
    opening, bracket = tokens[i], tokens[i + 1]
    if opening.kind != "name" or opening.text != "p" or bracket.kind != "op" or bracket.text != "[":
        return None
    j = i + 2
    values: list[Value] = []
    for separator in _SEPARATORS:
        tok = tokens[j]
        sign: Token | None = None
        if tok.kind == "op" and tok.text in ("-", "+"):
            sign, j = tok, j + 1
            tok = tokens[j] if j < len(tokens) else tok
        after = tokens[j + 1] if j + 1 < len(tokens) else None
        if tok.kind != "number" or after is None or after.kind != "op" or after.text != separator:
            return None
        values.append(signed_number(sign, tok))
        j += 2
    cur.i = j
    return Pose(opening, tuple(values), j)


def _element(cur: Cursor) -> Value:
    return literal_or_expression(cur, "]", "a pose element")


def pose_matrix(pose: Pose) -> Array | None:
    if not all(isinstance(v, Number) for v in pose.values):
        return None
    x, y, z, rx, ry, rz = (v.value for v in pose.values if isinstance(v, Number))
    return transform([1e3 * x, 1e3 * y, 1e3 * z], rotvec_matrix([rx, ry, rz]))


@dataclass
class Event:
    at: int
    stack: list[Context]
    pose: Pose | None = None
    name: Token | None = None
    assigned: str | None = None
    joints: JointMove | None = None
    """`movej([q1, ..., q6], ...)`: the joints of a joint move (radians)."""
    call: Token | None = None
    """A statement that calls a function URScript does not have (or, with `defines`, the script's own `def`)."""
    defines: bool = False


BUILTIN_PREFIXES = (
    "move", "servo", "speed", "stop", "set_", "get_", "socket_", "modbus_", "rpc_", "read_", "write_", "track_",
    "end_", "zero_", "force_", "freedrive", "teach_", "textmsg", "popup", "sleep", "sync", "halt", "conveyor_",
    "enable_", "disable_", "position_deviation", "request_", "is_", "pose_", "interpolate_", "to_", "str_",
    "tool_", "screw_", "path_", "payload_", "timer", "sqrt", "sin", "cos", "tan", "norm", "floor", "ceil",
    "len", "log", "pow", "random", "binary_list", "integer_to", "d2r", "r2d", "abs", "point_dist", "wrench_",
    "acos", "asin", "atan",
)  # fmt: skip
"""URScript's own functions (its manual's families): none of them sets the TCP but set_tcp, which is followed."""
KEYWORDS = frozenset({"if", "elif", "while", "return", "not", "and", "or", "def", "thread", "run", "join", "kill"})


def _joint_list(tokens: list[Token], i: int) -> tuple[JointMove, int] | None:
    """`[q1, q2, ...]` of plain signed numbers at token i: the joints and the index after `]` (None: not such)."""
    values: list[float] = []
    k = i + 1
    while k < len(tokens):
        sign = -1.0 if tokens[k].kind == "op" and tokens[k].text == "-" else 1.0
        k += tokens[k].kind == "op" and tokens[k].text in ("-", "+")
        if k >= len(tokens) or tokens[k].kind != "number":
            return None
        values.append(sign * float(tokens[k].text))
        k += 1
        if k < len(tokens) and tokens[k].kind == "op" and tokens[k].text == "]":
            return JointMove(tuple(values), tokens[i].line), k + 1
        if k >= len(tokens) or not (tokens[k].kind == "op" and tokens[k].text == ","):
            return None
        k += 1
    return None


def _operator(tokens: list[Token], i: int, stack: list[Context], events: list[Event], file: str | None) -> int:
    """A bracket or a comma at token i: the call stack kept; a movej's joint list read whole. The next index."""
    tok = tokens[i]
    text = tok.text
    if text == "[" and stack and stack[-1].name == "movej" and stack[-1].argument == 0:
        found = _joint_list(tokens, i)
        if found is not None:
            events.append(Event(i, _snapshot(stack), joints=found[0]))
            return found[1]
    if text in {"(", "["}:
        prev = tokens[i - 1] if i else None
        stack.append(Context(prev.text if text == "(" and prev is not None and prev.kind == "name" else ""))
    elif text in {")", "]"}:
        if not stack:
            raise Cursor(tokens, file, "the program").error(f"unbalanced {text!r}", tok)
        stack.pop()
    elif text == "," and stack:
        stack[-1].argument += 1
    return i + 1


def _scan(tokens: list[Token], file: str | None) -> list[Event]:
    """The pose literals and the names standing as whole arguments, with the calls around them, in order."""
    stack: list[Context] = []
    events: list[Event] = []
    i = 0
    n = len(tokens)
    while i < n:
        # Kinds and texts compared directly, neighbours fetched only where needed: this loop visits every token
        # of the program.
        tok = tokens[i]
        kind = tok.kind
        if kind == "op":
            i = _operator(tokens, i, stack, events, file)
            continue
        if kind == "name":
            nxt = tokens[i + 1] if i + 1 < n else None
            prev = tokens[i - 1] if i else None
            if tok.text == "p" and nxt is not None and nxt.kind == "op" and nxt.text == "[":
                cur = Cursor(tokens, file, "the pose")
                cur.i = i
                pose = parse_pose(cur)
                assigned = None
                if (
                    prev is not None
                    and prev.kind == "op"
                    and prev.text == "="
                    and i >= 2
                    and tokens[i - 2].kind == "name"
                ):
                    assigned = tokens[i - 2].text
                events.append(Event(i, _snapshot(stack), pose=pose, assigned=assigned))
                i = pose.end
                continue
            if (
                not stack
                and nxt is not None
                and nxt.kind == "op"
                and nxt.text == "("
                and tok.text not in KEYWORDS
                and not tok.text.startswith(BUILTIN_PREFIXES)
            ):
                header = prev is not None and prev.kind == "name" and prev.text in ("def", "thread")
                events.append(Event(i, [], call=tok, defines=header))
            if stack and _whole_argument(prev, nxt):
                if stack[-1].name == "pose_trans" and stack[-1].argument == 0:
                    stack[-1].feature = tok.text
                events.append(Event(i, _snapshot(stack), name=tok))
        i += 1
    return events


def _snapshot(stack: list[Context]) -> list[Context]:
    return [Context(c.name, c.argument, c.feature) for c in stack]


def _whole_argument(prev: Token | None, nxt: Token | None) -> bool:
    return (
        prev is not None
        and prev.kind == "op"
        and prev.text in ("(", ",")
        and nxt is not None
        and nxt.kind == "op"
        and nxt.text in (",", ")")
    )


def _motion_base(stack: list[Context]) -> tuple[bool, str | None]:
    """Whether a value in this place is a motion's pose, and the feature it is placed in (pose_trans)."""
    if stack and stack[-1].name in MOTIONS and stack[-1].argument in MOTIONS[stack[-1].name]:
        return True, None
    if (  # movej(get_inverse_kin(p[...])): the joints of a pose, which the move goes to
        len(stack) >= 2
        and stack[-1].name == "get_inverse_kin"
        and stack[-1].argument == 0
        and stack[-2].name in MOTIONS
        and stack[-2].argument in MOTIONS[stack[-2].name]
    ):
        return True, None
    if (
        len(stack) >= 2
        and stack[-1].name == "pose_trans"
        and stack[-1].argument == 1
        and stack[-2].name in MOTIONS
        and stack[-2].argument in MOTIONS[stack[-2].name]
    ):
        return True, stack[-1].feature
    return False, None


@dataclass
class Reading:
    variables: dict[str, list[tuple[int, Pose]]] = field(default_factory=dict)
    targets: list[tuple[Pose, Frames, str | None, JointMove | None]] = field(default_factory=list)
    warnings: dict[int, str] = field(default_factory=dict)
    """By the token index of a pose's literal: the warning of its first motion after a call not followed."""
    uses: dict[int, list[tuple[Frames, int, str | None, JointMove | None]]] = field(default_factory=dict)
    """By the token index of a variable's literal: the frames of each motion naming it, and the line."""

    def latest(self, name: str, before: int) -> Pose | None:
        found = [pose for at, pose in self.variables.get(name, []) if at < before]
        return found[-1] if found else (self.variables[name][-1][1] if name in self.variables else None)


def _frame(reading: Reading, name: Token, at: int, file: str | None) -> Array:
    pose = reading.latest(name.text, at)
    matrix = pose_matrix(pose) if pose is not None else None
    if matrix is None:
        raise undeclared(
            f"{name.text} is used as a frame but no literal pose is given to it in the program", file, name
        )
    return matrix


def _tcp(
    reading: Reading, e: Event, file: str | None, current: tuple[Array | None, str | None]
) -> tuple[Array | None, str | None, str | None]:
    """`set_tcp(...)`: the tool, its name, and why it cannot be read (a TCP the script computes)."""
    if e.pose is not None:
        return pose_matrix(e.pose), "set_tcp(p[...])", None
    if e.name is None:
        return (*current, None)
    try:
        return _frame(reading, e.name, e.at, file), e.name.text, None
    except UndeclaredFrame:
        why = (
            f"the tool set at line {e.name.line} (set_tcp({e.name.text})) is computed at run time: the target's TCP "
            "is not known from the text"
        )
        return None, e.name.text, why


def _read_events(events: list[Event], file: str | None) -> Reading:
    reading = Reading()
    for e in events:
        if e.pose is not None and e.assigned is not None:
            reading.variables.setdefault(e.assigned, []).append((e.at, e.pose))
    tool: Array | None = None
    tool_name: str | None = None
    tool_unknown: str | None = None
    """Why the active tool cannot be read (`set_tcp(computed)`): the motions after it keep their targets."""
    after: JointMove | None = None
    defined = {x.call.text for x in events if x.call is not None and x.defines}
    unfollowed: Token | None = None
    """The last call of a function neither the script nor URScript defines since the TCP was last set."""
    for e in events:
        if e.joints is not None:
            after = e.joints
            continue
        if e.call is not None:
            # A function the script defines is read where it is written (its set_tcp in the text's order).
            unfollowed = e.call if e.call.text not in defined else unfollowed
            continue
        in_tcp = bool(e.stack) and e.stack[-1].name == "set_tcp" and e.stack[-1].argument == 0
        motion, feature = _motion_base(e.stack)
        if in_tcp:
            tool, tool_name, tool_unknown = _tcp(reading, e, file, (tool, tool_name))
            unfollowed = None
            continue
        if not motion:
            continue
        base = np.eye(4)
        why = tool_unknown
        if feature is not None:
            token = next(x.name for x in events if x.name is not None and x.name.text == feature and x.at < e.at)
            try:
                base = _frame(reading, token, e.at, file)
            except UndeclaredFrame:
                why = why or (
                    f"placed by pose_trans({feature}, ...) in a feature computed at run time (line {token.line}): "
                    "its base is not known from the text"
                )
        _record(reading, e, Frames(base, tool, feature, tool_name), why, after=after, unfollowed=unfollowed)
    return reading


def _record(
    reading: Reading, e: Event, frames: Frames, why: str | None, *, after: JointMove | None, unfollowed: Token | None
) -> None:
    """A motion's pose (a literal, or the variable it names) with its frames, and the warning of a call before it
    that could not be followed."""
    warning = None if unfollowed is None else unfollowed_call(f"{unfollowed.text}( )", unfollowed.line, "TCP")
    if e.pose is not None:
        reading.targets.append((e.pose, frames, why, after))
        if warning is not None:
            reading.warnings[e.pose.open.start] = warning
    elif e.name is not None and (pose := reading.latest(e.name.text, e.at)) is not None:
        reading.uses.setdefault(pose.open.start, []).append((frames, e.name.line, why, after))
        if warning is not None:
            reading.warnings.setdefault(pose.open.start, warning)


def _matrices(poses: Sequence[Pose]) -> list[Array | None]:
    """`pose_matrix` of each pose, the literal ones in one numpy batch (one by one, 8 µs a pose)."""
    literal = [all(isinstance(v, Number) for v in pose.values) for pose in poses]
    values = np.array(
        [
            [v.value for v in pose.values if isinstance(v, Number)]
            for pose, ok in zip(poses, literal, strict=True)
            if ok
        ],
        dtype=float,
    ).reshape(-1, 6)
    out = np.tile(np.eye(4), (values.shape[0], 1, 1))
    out[:, :3, :3] = rotvec_to_matrix_np(values[:, 3:])
    out[:, :3, 3] = 1e3 * values[:, :3]
    matrices = iter(out)
    return [next(matrices) if ok else None for ok in literal]


def read(program: str, files: Mapping[str, str]) -> Program:
    """The Cartesian targets of a URScript program (a script is one text: `files` are not read)."""
    del files
    events = _scan(LEXER.tokens(program, PROGRAM), PROGRAM)
    reading = _read_events(events, PROGRAM)
    found: list[tuple[Pose, str | None, Frames, str | None, JointMove | None]] = [
        (pose, None, frames, why, after) for pose, frames, why, after in reading.targets
    ]
    for name, assigned in reading.variables.items():
        for _, pose in assigned:
            uses = reading.uses.get(pose.open.start, [])
            if not uses:  # a pose no motion goes to: an offset, a feature, a TCP
                found.append((pose, name, Frames(), DATA, None))
                continue
            frames, why = uses[0][0], next((w for _, _, w, _ in uses if w), None)
            for other, line, _, _ in uses[1:]:
                if not _same(other, frames):
                    why = f"used with different features or tools (lines {uses[0][1]} and {line})"
            found.append((pose, name, frames, why, uses[0][3]))
    # pose_trans(W, p[...]) is compensated in W's frame as written; where W is itself a target the program moves
    # to, W's own correction would be added on top: those are listed instead.
    moved = {name for pose, name, _, why, _ in found if name is not None and why is None}
    found = [
        (pose, name, frames, why or (_IN_MOVED.format(frames.base_name) if frames.base_name in moved else None), after)
        for pose, name, frames, why, after in found
    ]
    targets = [
        target_at(
            PROGRAM,
            name,
            pose.open,
            pose.values,
            matrix,
            frames=frames,
            kept=why or (None if matrix is not None else "not literal numbers: the pose is known only at run time"),
            style="rotvec",
            after=after,
            warning=reading.warnings.get(pose.open.start),
        )
        for (pose, name, frames, why, after), matrix in zip(found, _matrices([f[0] for f in found]), strict=True)
    ]
    return Program(NAME, {PROGRAM: program}, tuple(sorted(targets, key=lambda t: (t.line, t.column))))


def _same(a: Frames, b: Frames) -> bool:
    tools = (a.tool is None and b.tool is None) or (
        a.tool is not None and b.tool is not None and np.allclose(a.tool, b.tool)
    )
    return tools and bool(np.allclose(a.base, b.base))


def numbers(targets: Sequence[Target], poses: Array) -> list[list[str]]:
    like = np.array([t.style.get("rotvec", (0.0, 0.0, 0.0)) for t in targets], dtype=float).reshape(-1, 3)
    values = np.hstack([poses[:, :3, 3] / 1e3, rotvecs_like(poses[:, :3, :3], like)])
    return [written(v, t.slots, METRE_DECIMALS) for v, t in zip(values, targets, strict=True)]
