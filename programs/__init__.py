"""Robot programs as their controllers read them: the Cartesian targets of KUKA KRL, ABB RAPID, URScript and
CSV files, found by each dialect's tokenizer and grammar with the characters of their numbers, and the
rewrite that replaces those numbers and keeps every other character.

Pure text and numpy: no HTTP, no database (pyproject.toml's import contracts); `models` only for its
rotation conventions. The numerical compensation of the targets is `models.compensation.compensate_poses`;
the service joins the two (`service/services/programs.py`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from models._types import Array
from programs import csv_poses, krl, rapid, urscript
from programs.errors import ProgramError, ProgramSyntaxError, UndeclaredFrame
from programs.targets import PROGRAM, Configuration, Frames, Program, Slot, Target, rewrite


@dataclass(frozen=True)
class Dialect:
    name: str
    read: Callable[[str, Mapping[str, str]], Program]
    """The program's text and its companion files by name -> its targets."""
    numbers: Callable[[Target, Array], list[str]]
    """A target and its new pose (4x4 in its base frame, mm) -> the texts of its slots."""
    extensions: tuple[str, ...]


DIALECTS: dict[str, Dialect] = {
    d.name: d
    for d in (
        Dialect(krl.NAME, krl.read, krl.numbers, (".src", ".dat", ".sub")),
        Dialect(rapid.NAME, rapid.read, rapid.numbers, (".mod", ".modx", ".prg", ".sys")),
        Dialect(urscript.NAME, urscript.read, urscript.numbers, (".script", ".urscript")),
        Dialect(csv_poses.NAME, csv_poses.read, csv_poses.numbers, (".csv",)),
    )
}


def dialect(name: str) -> Dialect:
    found = DIALECTS.get(name.lower())
    if found is None:
        raise ProgramError(f"unknown program format {name!r}: one of {', '.join(DIALECTS)}", reason="unknown-format")
    return found


def dialect_of_file(filename: str) -> Dialect | None:
    lower = filename.lower()
    return next((d for d in DIALECTS.values() if lower.endswith(d.extensions)), None)


def read_program(name: str, program: str, files: Mapping[str, str] | None = None) -> Program:
    return dialect(name).read(program, dict(files or {}))


def rewritten(program: Program, changes: Sequence[tuple[Target, Array]]) -> dict[str | None, str]:
    """The program's texts with each changed target's numbers written for its new pose (4x4, its base frame)."""
    numbers = dialect(program.format).numbers
    edits = [
        (slot, text) for target, pose in changes for slot, text in zip(target.slots, numbers(target, pose), strict=True)
    ]
    return rewrite(program.texts, edits)


__all__ = [
    "DIALECTS",
    "PROGRAM",
    "Configuration",
    "Dialect",
    "Frames",
    "Program",
    "ProgramError",
    "ProgramSyntaxError",
    "Slot",
    "Target",
    "UndeclaredFrame",
    "dialect",
    "dialect_of_file",
    "read_program",
    "rewritten",
]
