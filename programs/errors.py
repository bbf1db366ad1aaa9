"""The errors of reading a robot program: what is wrong and where (file, line, column, 1-based)."""

from __future__ import annotations

from typing import ClassVar

from models.errors import InvalidInput


class ProgramError(InvalidInput):
    """A program (or one of its files) that cannot be read as its dialect: a syntax error in a target's
    declaration, a target taught in an undeclared base or tool, bytes that are not text."""

    fields: ClassVar[tuple[str, ...]] = ("file", "line", "column", "reason")

    def __init__(
        self,
        detail: str,
        *,
        file: str | None = None,
        line: int | None = None,
        column: int | None = None,
        reason: str | None = None,
    ) -> None:
        where = ":".join(str(x) for x in (file, line, column) if x is not None)
        super().__init__(f"{where}: {detail}" if where else detail, reason=reason)
        self.file = file
        """The file named in the request's `files`, or None for the program itself."""
        self.line = line
        self.column = column


class ProgramSyntaxError(ProgramError):
    """The text does not follow the dialect's grammar where a target or a frame is declared or used."""


class UndeclaredFrame(ProgramError):
    """A target is taught in a base (work object) or with a tool the program and its files do not declare."""
