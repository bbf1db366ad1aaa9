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

import numpy as np

from models._types import Array
from programs import csv_poses, krl, rapid, urscript
from programs.collection import collector_paused
from programs.errors import ProgramError, ProgramSyntaxError, UndeclaredFrame
from programs.targets import PROGRAM, Configuration, Frames, Program, Slot, Target, rewrite


@dataclass(frozen=True)
class Dialect:
    name: str
    read: Callable[[str, Mapping[str, str]], Program]
    """The program's text and its companion files by name -> its targets."""
    numbers: Callable[[Sequence[Target], Array], list[list[str]]]
    """Targets and their new poses ((N, 4, 4) in their base frames, mm) -> the texts of each one's slots."""
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
    reader = dialect(name).read
    with collector_paused():
        return reader(program, dict(files or {}))


def rewritten(program: Program, changes: Sequence[tuple[Target, Array]]) -> dict[str | None, str]:
    """The program's texts with each changed target's numbers written for its new pose (4x4, its base frame)."""
    if not changes:
        return rewrite(program.texts, [])
    targets = [target for target, _ in changes]
    numbers = dialect(program.format).numbers
    with collector_paused():
        texts = numbers(targets, np.array([pose for _, pose in changes]))
        edits = [
            (slot, text)
            for target, new in zip(targets, texts, strict=True)
            for slot, text in zip(target.slots, new, strict=True)
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
