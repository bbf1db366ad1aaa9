"""Values of the bracketed literals the dialects write targets and frames with, as read by their parsers: a
number keeps its token (the slot a rewrite replaces), anything that is not a literal keeps where it starts."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from programs.lexer import Cursor, Token
from programs.numbers import parse_number


class Number(NamedTuple):
    """A literal number: its value and its characters (the sign, if written apart, is part of the span). A
    tuple: a program has six or seven of them a target, and a tuple is several times cheaper to make than a
    frozen dataclass."""

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


def plain_number(cur: Cursor, close: str) -> Number | None:
    """The common item, a (signed) number then `,` or `close`, read straight off the token list (the general
    reading costs a dozen method calls an item; a 10 000-target program has 60 000 items); None otherwise,
    the cursor unmoved."""
    tokens, i = cur.tokens, cur.i
    if i + 2 >= len(tokens):
        return None
    sign: Token | None = tokens[i]
    if sign is not None and sign.kind == "op" and sign.text in ("-", "+"):
        i += 1
    else:
        sign = None
    first, nxt = tokens[i], tokens[i + 1]
    if first.kind == "number" and nxt.kind == "op" and nxt.text in (",", close):
        cur.i = i + 1
        return signed_number(sign, first)
    return None


def literal_or_expression(cur: Cursor, close: str, what: str) -> Value:
    """One item of a bracketed literal, up to its `,` or its closing bracket `close`: a (signed) number, or
    anything else read to the item's end and kept as written (an expression, a name, a string, an enumeration).
    Nothing at all is a syntax error naming what is missing."""
    plain = plain_number(cur, close)
    if plain is not None:
        return plain
    sign = cur.accept("op", "-") or cur.accept("op", "+")
    first = cur.next()
    nxt = cur.peek()
    if first.kind == "number" and (nxt is None or nxt.is_("op", ",") or nxt.is_("op", close)):
        return signed_number(sign, first)
    if first.is_("op", ",") or first.is_("op", close):
        raise cur.error(f"{what} is missing before {first.text!r}", first)
    depth, text = int(first.kind == "op" and first.text in "([{"), first.text
    while (nxt := cur.peek()) is not None and not (depth == 0 and (nxt.is_("op", ",") or nxt.is_("op", close))):
        if nxt.is_("op", ";") and close == "]":
            raise cur.error("the statement ends inside an aggregate", nxt)
        depth += nxt.kind == "op" and nxt.text in "([{"
        depth -= nxt.kind == "op" and nxt.text in ")]}"
        text += cur.next().text
    return Opaque(sign or first, (sign.text if sign else "") + text)
