"""A tokenizer shared by the dialects: each gives its token kinds as regular expressions, tried in order at
each position; every character of the text belongs to exactly one token, so the tokens' spans cover the text
and a rewrite can replace a number's characters and keep every other byte."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from itertools import compress, repeat
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from programs.errors import ProgramSyntaxError, UndeclaredFrame


class Token(NamedTuple):
    """A tuple (~3x cheaper to make than a frozen dataclass: a 10 000-target program has 450 000 tokens)."""

    kind: str
    text: str
    start: int
    """Character offset in the text (the text is the decoded program: offsets count characters)."""
    line: int
    column: int
    """1-based line and column."""

    @property
    def end(self) -> int:
        return self.start + len(self.text)

    def is_(self, kind: str, text: str | None = None, *, fold: bool = True) -> bool:
        if self.kind != kind:
            return False
        if text is None or self.text == text:
            return True
        return fold and self.text.lower() == text.lower()


class Lexer:
    """Tokens of a dialect: `spec` is (kind, pattern) in the order they are tried; kinds in `skip` (blanks,
    comments) are dropped from the stream the parsers read, `newline` tokens are kept where lines matter."""

    def __init__(self, spec: Sequence[tuple[str, str]], *, skip: frozenset[str], flags: int = 0) -> None:
        self.pattern = re.compile("|".join(f"(?P<{kind}>{pat})" for kind, pat in spec), flags)
        self.skip = skip

    def tokens(self, text: str, file: str | None = None) -> list[Token]:
        # One pass of the compiled pattern collects (kind, text, start) per match; lines, columns, the check that
        # the matches tile the text and the tokens themselves are made by whole-list operations after it (zip,
        # compress, numpy, `tuple.__new__` mapped): per match that is the least Python there can be (a loop
        # that tracked the line per token took 1.5 s of 450 000 tokens, one that built each token 0.16 s).
        found = [(m.lastgroup or "", m.group(), m.start()) for m in self.pattern.finditer(text)]
        kinds, texts, offsets = zip(*found, strict=True) if found else ((), (), ())
        starts = np.array(offsets, dtype=np.int64)
        ends = starts + np.fromiter(map(len, texts), dtype=np.int64, count=len(texts))
        expected = np.r_[0, ends[:-1]]
        # A character no token starts with leaves a gap before the next match (an empty match would loop).
        broken = np.flatnonzero((starts != expected) | (ends == starts))
        stop = int(broken[0]) if broken.size else len(found)
        covered = int(ends[stop - 1]) if stop else 0  # the text up to here is tiled by tokens
        newlines = np.array([m.start() for m in _NEWLINE.finditer(text)], dtype=np.int64)
        if covered < len(text):
            raise _syntax_error(
                f"unexpected character {text[covered]!r}", "unexpected-character", newlines, covered, file
            )
        if _HUGE.search(text):  # C speed; only a text with a 3-digit exponent or 309 digits is checked by token
            _finite_numbers(kinds, texts, starts, newlines, file)
        skip = self.skip
        keep = [kind not in skip for kind in kinds]
        lines, columns = _line_column(newlines, starts[np.array(keep, dtype=bool)])
        rows = zip(
            compress(kinds, keep),
            compress(texts, keep),
            compress(offsets, keep),
            lines.tolist(),
            columns.tolist(),
            strict=True,
        )
        return list(map(tuple.__new__, repeat(Token), rows))


_NEWLINE = re.compile("\n")
_HUGE = re.compile(r"[eE]\+?0*\d{3}|\d{309}")
"""What a number past a double's range (1e308) must contain somewhere in the text."""


def _finite_numbers(
    kinds: tuple[str, ...],
    texts: tuple[str, ...],
    starts: NDArray[np.int64],
    newlines: NDArray[np.int64],
    file: str | None,
) -> None:
    """A number token that overflows a double (`1e400`) is a syntax error at its place, not an infinity."""
    for k, (kind, text) in enumerate(zip(kinds, texts, strict=True)):
        if kind == "number" and not math.isfinite(float(text)):
            raise _syntax_error(
                f"the number {text[:40]!r} is out of range (beyond ±1.8e308): a value a controller cannot hold",
                "number-out-of-range",
                newlines,
                int(starts[k]),
                file,
            )


def _syntax_error(
    detail: str, reason: str, newlines: NDArray[np.int64], offset: int, file: str | None
) -> ProgramSyntaxError:
    """The error at character `offset` of the text, named by its line and column."""
    line, column = _line_column(newlines, np.array([offset], dtype=np.int64))
    return ProgramSyntaxError(detail, file=file, line=int(line[0]), column=int(column[0]), reason=reason)


def _line_column(
    newlines: NDArray[np.int64], offsets: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """1-based line and column of character offsets, from the offsets of the text's line feeds."""
    before = np.searchsorted(newlines, offsets, side="left")  # line feeds before each offset
    line_start = np.where(before > 0, newlines[np.maximum(before - 1, 0)] + 1, 0) if newlines.size else 0
    return before + 1, offsets - line_start + 1


MAX_NESTING = 16


class Cursor:
    """A parser's position in a token list, with the errors that name the token where the grammar broke."""

    def __init__(self, tokens: list[Token], file: str | None, what: str) -> None:
        self.tokens, self.file, self.what, self.i = tokens, file, what, 0
        self.depth = 0
        """Aggregates open around the position: the readers recurse into nested ones."""

    def enter(self, tok: Token) -> None:
        """One aggregate deeper; refused past `MAX_NESTING` (a robtarget nests 3 deep, a KRL FDAT 2), before
        Python's recursion limit would turn a hostile program into an internal error."""
        self.depth += 1
        if self.depth > MAX_NESTING:
            raise self.error(f"aggregates nested more than {MAX_NESTING} deep", tok)

    def leave(self) -> None:
        self.depth -= 1

    def peek(self, ahead: int = 0) -> Token | None:
        k = self.i + ahead
        return self.tokens[k] if k < len(self.tokens) else None

    def next(self) -> Token:
        tok = self.peek()
        if tok is None:
            last = self.tokens[-1] if self.tokens else None
            raise self.error(f"{self.what} ends early", last)
        self.i += 1
        return tok

    def expect(self, kind: str, text: str | None = None) -> Token:
        tok = self.next()
        if not tok.is_(kind, text):
            want = repr(text) if text is not None else kind
            raise self.error(f"expected {want} in {self.what}, found {tok.text!r}", tok)
        return tok

    def accept(self, kind: str, text: str | None = None) -> Token | None:
        tok = self.peek()
        if tok is not None and tok.is_(kind, text):
            self.i += 1
            return tok
        return None

    def error(self, detail: str, tok: Token | None) -> ProgramSyntaxError:
        return ProgramSyntaxError(
            detail,
            file=self.file,
            line=tok.line if tok else None,
            column=tok.column if tok else None,
            reason="syntax",
        )


def undeclared(detail: str, file: str | None, tok: Token) -> UndeclaredFrame:
    """A base or tool named at `tok` that the program and its files do not declare."""
    return UndeclaredFrame(detail, file=file, line=tok.line, column=tok.column, reason="undeclared-frame")
