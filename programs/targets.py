"""What a dialect finds in a program: its Cartesian targets, each with the characters of its numbers, the
frames it is taught in and its configuration, and the rewrite that replaces those numbers and nothing else."""

from __future__ import annotations

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
) -> Target:
    """A target from its literal: `values` are its position then its rotation's numbers as written (None or
    Opaque where not a number: no slot), the rotation's also kept as `style` for writing it back nearby."""
    slots = tuple(Slot(file, v.start, v.end, v.text) for v in values if isinstance(v, Number))
    like = tuple(v.value if isinstance(v, Number) else 0.0 for v in values[3:])
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
    )
