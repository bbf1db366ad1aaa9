"""Values of the bracketed literals the dialects write targets and frames with, as read by their parsers: a
number keeps its token (the slot a rewrite replaces), anything that is not a literal keeps where it starts."""

from __future__ import annotations

from dataclasses import dataclass

from programs.lexer import Token
from programs.numbers import parse_number


@dataclass(frozen=True)
class Number:
    """A literal number: its value and its characters (the sign, if written apart, is part of the span)."""

    value: float
    first: Token
    last: Token

    @property
    def start(self) -> int:
        return self.first.start

    @property
    def end(self) -> int:
        return self.last.end

    @property
    def text(self) -> str:
        return self.first.text + self.last.text if self.first is not self.last else self.first.text


@dataclass(frozen=True)
class Opaque:
    """A value that is not a literal number: an expression, a name, a string, an enumeration."""

    first: Token
    text: str


Value = Number | Opaque


def signed_number(sign: Token | None, tok: Token) -> Number:
    value = parse_number(tok.text)
    if sign is not None and sign.text == "-":
        value = -value
    return Number(value, sign if sign is not None else tok, tok)
