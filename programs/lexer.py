"""A tokenizer shared by the dialects: each gives its token kinds as regular expressions, tried in order at
each position; every character of the text belongs to exactly one token, so the tokens' spans cover the text
and a rewrite can replace a number's characters and keep every other byte."""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import NamedTuple

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
        if text is None:
            return True
        return self.text.lower() == text.lower() if fold else self.text == text


class Lexer:
    """Tokens of a dialect: `spec` is (kind, pattern) in the order they are tried; kinds in `skip` (blanks,
    comments) are dropped from the stream the parsers read, `newline` tokens are kept where lines matter."""

    def __init__(self, spec: Sequence[tuple[str, str]], *, skip: frozenset[str], flags: int = 0) -> None:
        self.pattern = re.compile("|".join(f"(?P<{kind}>{pat})" for kind, pat in spec), flags)
        self.skip = skip

    def tokens(self, text: str, file: str | None = None) -> list[Token]:
        out: list[Token] = []
        pos, line, line_start = 0, 1, 0
        skip = self.skip
        for m in self.pattern.finditer(text):
            if m.start() != pos or m.end() == pos:
                break  # a character no token starts with (an empty match would loop)
            kind = m.lastgroup or ""
            piece = m.group()
            if kind not in skip:
                out.append(Token(kind, piece, pos, line, pos - line_start + 1))
            if "\n" in piece:
                line += piece.count("\n")
                line_start = pos + piece.rindex("\n") + 1
            pos = m.end()
        if pos < len(text):
            raise ProgramSyntaxError(
                f"unexpected character {text[pos]!r}",
                file=file,
                line=line,
                column=pos - line_start + 1,
                reason="unexpected-character",
            )
        return out


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
