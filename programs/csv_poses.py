"""A CSV of poses: one target a row, in the robot's base frame, mm and degrees.

The first line that is not blank or a `#` comment is the header; it names the columns (any case, any order,
other columns kept as they are): `x, y, z` in mm, and the orientation as one of `a, b, c` (KUKA's angles, R =
Rz(A)·Ry(B)·Rx(C), degrees), `qw, qx, qy, qz` (a unit quaternion, scalar first) or `rx, ry, rz` (a rotation
vector, axis times angle in degrees); a `name` column names the targets. The separator is the header's: `;`,
tab or `,`. Fields may be quoted (`"1.5"`, `""` inside quotes is a quote); line ends (CRLF or LF) are kept.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from models._types import Array
from programs.errors import ProgramSyntaxError
from programs.frames import (
    abc_matrix,
    abcs_like,
    quaternion_matrix,
    quaternions_like,
    rotvec_matrix,
    rotvecs_like,
    transform,
)
from programs.numbers import parse_number
from programs.targets import PROGRAM, Frames, Program, Slot, Target, absurd, written

NAME = "csv"
ORIENTATIONS: dict[str, tuple[str, ...]] = {
    "abc": ("a", "b", "c"),
    "quaternion": ("qw", "qx", "qy", "qz"),
    "rotvec": ("rx", "ry", "rz"),
}
MIN_DECIMALS = {"abc": (3, 3, 3, 4, 4, 4), "quaternion": (3, 3, 3, 6, 6, 6, 6), "rotvec": (3, 3, 3, 4, 4, 4)}


@dataclass(frozen=True)
class Field:
    text: str
    start: int
    """Offset of the field's value in the whole text (inside its quotes)."""
    column: int


def fields(line: str, offset: int, sep: str, line_no: int) -> list[Field]:
    """The fields of one line, each with where its value starts (a real CSV reader: quotes, doubled quotes)."""
    out: list[Field] = []
    i = 0
    while True:
        while i < len(line) and line[i] in " \t" and line[i] != sep:
            i += 1
        if i < len(line) and line[i] == '"':
            j, parts = i + 1, []
            while True:
                k = line.find('"', j)
                if k < 0:
                    raise ProgramSyntaxError("unterminated quote", line=line_no, column=i + 1, reason="syntax")
                parts.append(line[j:k])
                if line[k + 1 : k + 2] == '"':
                    parts.append('"')
                    j = k + 2
                    continue
                break
            out.append(Field("".join(parts), offset + i + 1, i + 1))
            i = k + 1
            while i < len(line) and line[i] in " \t" and line[i] != sep:
                i += 1
            if i < len(line) and line[i] != sep:
                raise ProgramSyntaxError(f"text after a quoted field: {line[i]!r}", line=line_no, column=i + 1)
        else:
            end = line.find(sep, i)
            end = len(line) if end < 0 else end
            raw = line[i:end]
            out.append(Field(raw.rstrip(" \t"), offset + i, i + 1))
            i = end
        if i >= len(line):
            return out
        i += 1  # the separator


def _layout(header: list[Field], line_no: int) -> tuple[list[int], str, int | None]:
    names = [f.text.strip().lstrip("\ufeff").lower() for f in header]  # a UTF-8 BOM before the first name
    for kind, cols in ORIENTATIONS.items():
        wanted = ("x", "y", "z", *cols)
        if all(c in names for c in wanted):
            name_col = names.index("name") if "name" in names else None
            return [names.index(c) for c in wanted], kind, name_col
    raise ProgramSyntaxError(
        f"the header {', '.join(names)} lacks x, y, z and one of a, b, c / qw, qx, qy, qz / rx, ry, rz",
        line=line_no,
        column=1,
        reason="csv-header",
    )


def _pose(values: list[float], kind: str) -> Array:
    p, rest = values[:3], values[3:]
    if kind == "abc":
        return transform(p, abc_matrix(*rest))
    if kind == "quaternion":
        return transform(p, quaternion_matrix(rest))
    return transform(p, np.asarray(_rotvec(rest)))


def _rotvec(deg: list[float]) -> Array:
    return rotvec_matrix(np.radians(deg))


def _lines(text: str) -> list[tuple[int, int, str]]:
    """(line number, offset, content without its line end) of each line."""
    out, offset = [], 0
    for k, raw in enumerate(text.splitlines(keepends=True), start=1):
        content = raw.rstrip("\r\n")
        out.append((k, offset, content))
        offset += len(raw)
    return out


def _separator(header: str) -> str:
    return ";" if ";" in header else ("\t" if "\t" in header else ",")


def read(program: str, files: Mapping[str, str]) -> Program:
    """One target a data row; a value that is not a number is a syntax error at its line and column."""
    del files
    layout: tuple[list[int], str, int | None] | None = None
    sep = ","
    targets: list[Target] = []
    for line_no, offset, content in _lines(program):
        if not content.strip() or content.lstrip().startswith("#"):
            continue
        if layout is None:
            sep = _separator(content)
            layout = _layout(fields(content, offset, sep, line_no), line_no)
            continue
        cols, kind, name_col = layout
        row = fields(content, offset, sep, line_no)
        if len(row) <= max(cols):
            raise ProgramSyntaxError(
                f"the row has {len(row)} fields, the header {max(cols) + 1} or more",
                line=line_no,
                column=len(content) + 1,
                reason="csv-row",
            )
        values = []
        for c in cols:
            try:
                values.append(parse_number(row[c].text))
            except ValueError:
                raise ProgramSyntaxError(
                    f"{row[c].text!r} is not a number", line=line_no, column=row[c].column, reason="syntax"
                ) from None
        slots = tuple(Slot(PROGRAM, row[c].start, row[c].start + len(row[c].text), row[c].text) for c in cols)
        # An absurd number is kept before any pose is made of it (cos of a 1e300° rotation vector raises).
        why = absurd(values[:3], [row[c].text for c in cols], values[3:], kind, degrees=True)
        targets.append(
            Target(
                file=PROGRAM,
                line=line_no,
                column=1,
                name=row[name_col].text if name_col is not None and name_col < len(row) else None,
                pose=_pose(values, kind) if why is None else np.full((4, 4), np.nan),
                slots=slots,
                frames=Frames(),
                style={"kind": kind, "like": tuple(values[3:])},
                kept=why,
            )
        )
    return Program(NAME, {PROGRAM: program}, tuple(targets))


def numbers(targets: Sequence[Target], poses: Array) -> list[list[str]]:
    """Each row's numbers in its table's orientation convention (one table has one)."""
    out = []
    for kind, cols in ORIENTATIONS.items():
        idx = [k for k, t in enumerate(targets) if t.style["kind"] == kind]
        if not idx:
            continue
        like = np.array([targets[k].style["like"] for k in idx], dtype=float).reshape(-1, len(cols))
        r = poses[idx, :3, :3]
        if kind == "abc":
            rotation = abcs_like(r, like)
        elif kind == "quaternion":
            rotation = quaternions_like(r, like)
        else:
            rotation = np.degrees(rotvecs_like(r, np.radians(like)))
        values = np.hstack([poses[idx, :3, 3], rotation])
        out += [(k, written(v, targets[k].slots, MIN_DECIMALS[kind])) for k, v in zip(idx, values, strict=True)]
    return [texts for _, texts in sorted(out)]
