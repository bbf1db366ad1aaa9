"""What a dialect finds in a program: its Cartesian targets, each with the characters of its numbers, the
frames it is taught in and its configuration, and the rewrite that replaces those numbers and nothing else."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from models._types import Array
from programs.aggregates import Number, Value
from programs.lexer import Token
from programs.numbers import styled

PROGRAM: str | None = None
"""The file key of the program text itself (the others are the names in the request's `files`)."""


class Slot(NamedTuple):
    """One number of a target in its file's text: replaced by the rewrite, character for character (a tuple:
    cheap to make, six or seven a target)."""

    file: str | None
    start: int
    end: int
    text: str

    @classmethod
    def of(cls, file: str | None, tok: Token) -> Slot:
        return cls(file, tok.start, tok.end, tok.text)


@dataclass(frozen=True)
class Frames:
    """The frames a target is taught in: `base` is robot base <- the program's base (work object), `tool`
    flange <- TCP (None: the program names no tool, the robot model's own tool applies)."""

    base: Array = field(default_factory=lambda: np.eye(4))
    tool: Array | None = None
    base_name: str | None = None
    tool_name: str | None = None


@dataclass(frozen=True)
class Configuration:
    """The joint configuration a target declares, as far as it is a property of the joints alone.

    `kind` "sign": `values[k]` is 1 where joint `joints[k]` is negative (KUKA's turn T), "quadrant": the
    quarter turn floor(q / 90°) of each joint (ABB's cf1, cf4, cf6)."""

    kind: str
    joints: tuple[int, ...]
    values: tuple[int, ...]
    text: str
    enforced: bool = True
    """The controller holds the motion to it (KUKA's T on a PTP, ABB's cf under ConfJ/ConfL On); False: it is a
    hint only (ABB's ConfL \\Off: the controller takes the solution nearest the current joints)."""


@dataclass(frozen=True)
class JointMove:
    """The joints of a joint motion the program makes before a target (the controller starts the target's solve
    from the arm's current joints): radians for revolute axes as the controller counts them."""

    joints: tuple[float, ...]
    line: int


@dataclass(frozen=True)
class Target:
    file: str | None
    line: int
    column: int
    name: str | None
    pose: Array
    """(4, 4) the TCP in the target's base frame, mm."""
    slots: tuple[Slot, ...]
    frames: Frames
    configuration: Configuration | None = None
    kept: str | None = None
    """Why the text alone says the target cannot be compensated (a partial aggregate, a relative motion)."""
    style: Mapping[str, object] = field(default_factory=dict)
    """What the dialect needs to write the target back (the source's angles, quaternion sign)."""
    after: JointMove | None = None
    """The program's last joint move before the target (in the text's order): where the controller's solve
    starts, so the branch it will take (None: no joint move precedes it)."""
    warning: str | None = None
    """What the text leaves uncertain about the target's frames (a call before it of a routine not among the
    files, which may set a base or a tool): compensated in the frames read, with this said."""


def unfollowed_call(name: str, line: int, frames: str, *, compensated: str = "set before the call") -> str:
    """The warning of a target after a call of a routine whose body was not sent. KRL and URScript set their
    frames in the order of the text ("set before the call"); RAPID's are data, whose values are read from the
    files ("read")."""
    return (
        f"after the call of {name} at line {line}, a routine not among the files: it may set the {frames}, which "
        f"could not be followed; the target was compensated in the frames {compensated} (send the file that "
        "defines it)"
    )


@dataclass(frozen=True)
class Program:
    format: str
    texts: Mapping[str | None, str]
    targets: tuple[Target, ...]


def written(values: Sequence[float], slots: Sequence[Slot], min_decimals: Sequence[int]) -> list[str]:
    return [styled(v, s.text, d) for v, s, d in zip(values, slots, min_decimals, strict=True)]


def rewrite(texts: Mapping[str | None, str], edits: Sequence[tuple[Slot, str]]) -> dict[str | None, str]:
    """Each file with its slots' characters replaced by the new numbers; every other character kept."""
    out: dict[str | None, str] = {}
    by_file: dict[str | None, list[tuple[Slot, str]]] = {}
    for slot, text in edits:
        by_file.setdefault(slot.file, []).append((slot, text))
    for name, text in texts.items():
        pieces, at = [], 0
        for slot, new in sorted(by_file.get(name, []), key=lambda e: e[0].start):
            pieces += [text[at : slot.start], new]
            at = slot.end
        pieces.append(text[at:])
        out[name] = "".join(pieces)
    return out


ABSURD_MM = 100_000.0
"""A position farther than this (100 m) from its base: beyond any arm's reach by more than an order of magnitude
(the largest industrial arms reach ~4 m), a typing or unit error, never a place a controller can go."""
ABSURD_TURNS = 4.0
"""An angle (or a rotation vector's length) of more than this many turns: controllers write orientations within
half a turn (KUKA's A, B, C in ±180°, UR's rotation vectors up to π); beyond a few turns the number is a mistake
and its meaning, an angle taken modulo a turn in floating point, is lost (cos(1e300°) is noise)."""

_ANGLE_NAMES = {"abc": ("A", "B", "C"), "rotvec": ("rx", "ry", "rz"), "quaternion": ("q1", "q2", "q3", "q4")}


def absurd(
    position_mm: Sequence[float], written: Sequence[str], rotation: Sequence[float], kind: str, *, degrees: bool
) -> str | None:
    """Why a target's finite numbers are no pose to compensate, naming the number as written (None: plausible).

    `position_mm`: x, y, z in mm; `written`: the target's numbers as written (position, then rotation);
    `rotation`: its rotation's numbers, `kind` "abc" (angles), "rotvec" (a rotation vector) or "quaternion";
    `degrees`: the angles' unit."""
    for axis, value, text in zip("xyz", position_mm, written, strict=False):
        if abs(value) > ABSURD_MM:
            return (
                f"{axis} = {text} is {abs(value) / 1e3:.3g} m from its base, beyond any robot's reach (more than "
                f"{ABSURD_MM / 1e3:g} m): a typing or unit error? kept as written"
            )
    names, texts = _ANGLE_NAMES.get(kind, ()), written[3:]
    turn = 360.0 if degrees else 2 * np.pi
    unit = "°" if degrees else " rad"
    if kind == "abc":
        for name, value, text in zip(names, rotation, texts, strict=False):
            if abs(value) > ABSURD_TURNS * turn:
                return _turns(f"{name} = {text}{unit}", abs(value) / turn)
    elif kind == "rotvec":
        length = math.hypot(*rotation) / turn  # in turns (hypot: no square of 1e300 taken)
        if length > ABSURD_TURNS:
            shown = ", ".join(texts) if texts else ", ".join(f"{v:g}" for v in rotation)
            return _turns(f"the rotation vector [{shown}] (length {length * turn:.3g}{unit})", length)
    elif kind == "quaternion":
        norm = math.hypot(*rotation)
        if not 0.5 <= norm <= 2.0:
            shown = ", ".join(texts) if texts else ", ".join(f"{v:g}" for v in rotation)
            return f"the quaternion [{shown}] has norm {norm:.3g}, not 1: not an orientation; kept as written"
    return None


def _turns(what: str, turns: float) -> str:
    return (
        f"{what} is {turns:.3g} turns: no controller writes an orientation so (at most {ABSURD_TURNS:g} turns are "
        "read), a typing or unit error? kept as written"
    )


def _written_mm(values: Sequence[Value | None], style: str) -> list[float]:
    """A literal's position in mm: URScript writes metres, the others mm."""
    scale = 1e3 if style == "rotvec" else 1.0
    return [v.value * scale if isinstance(v, Number) else 0.0 for v in values[:3]]


def target_at(
    file: str | None,
    name: str | None,
    opening: Token,
    values: Sequence[Value | None],
    pose: Array | None,
    *,
    frames: Frames,
    kept: str | None,
    configuration: Configuration | None = None,
    style: str,
    after: JointMove | None = None,
    warning: str | None = None,
) -> Target:
    """A target from its literal: `values` are its position then its rotation's numbers as written (None or
    Opaque where not a number: no slot), the rotation's also kept as `style` for writing it back nearby."""
    slots = tuple(Slot(file, v.start, v.end, v.text) for v in values if isinstance(v, Number))
    like = tuple(v.value if isinstance(v, Number) else 0.0 for v in values[3:])
    if kept is None and pose is not None and len(values) >= 6 and all(isinstance(v, Number) for v in values):
        texts = [v.text for v in values if isinstance(v, Number)]
        kept = absurd(_written_mm(values, style), texts, like, style, degrees=style == "abc")
    return Target(
        file=file,
        line=opening.line,
        column=opening.column,
        name=name,
        pose=pose if pose is not None else np.full((4, 4), np.nan),
        slots=slots,
        frames=frames,
        configuration=configuration,
        kept=kept,
        style={style: like},
        after=after,
        warning=warning,
    )
