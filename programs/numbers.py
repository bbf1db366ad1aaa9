"""Numbers written back in the style of the ones they replace: the same number of decimals (at least enough
for the correction to survive), an exponent where the source had one, a sign only where needed."""

from __future__ import annotations

import math
import re

_NUMBER = re.compile(r"^[+-]?(?P<int>\d*)(?:\.(?P<frac>\d*))?(?P<exp>[eE][+-]?\d+)?$")


def decimals(text: str) -> int:
    m = _NUMBER.match(text.strip())
    return len(m.group("frac") or "") if m else 0


def styled(value: float, like: str, min_decimals: int) -> str:
    """`value` written as `like` is: its decimals (or `min_decimals` if more are needed), its exponent style.

    A value that rounds to zero is written without a sign ("-0.000" would read as a change)."""
    stripped = like.strip()
    point = stripped.find(".")
    if point > 0 and stripped[point + 1 :].isdecimal() and stripped[:point].removeprefix("-").isdecimal():
        # The common spelling, [-]digits.digits (a program's numbers: 60 000 of these calls), without the regex.
        text = f"{value:.{max(len(stripped) - point - 1, min_decimals)}f}"
        return text[1:] if text[0] == "-" and not text.strip("-0.") else text
    m = _NUMBER.match(stripped)
    written_places = len(m.group("frac") or "") if m else 0  # decimals(like), without matching it twice
    places = max(written_places, min_decimals)
    if m is not None and m.group("exp"):
        exp = m.group("exp")
        upper = exp[0] == "E"
        # `min_decimals` counts places of the value, the mantissa's count from its first digit: 1000.05 needs
        # 1.00005E3, five of them.
        magnitude = math.floor(math.log10(abs(value))) if value != 0 else 0
        places = max(written_places, min_decimals + magnitude, 0)
        text = f"{value:.{places}{'E' if upper else 'e'}}"
        mantissa, _, power = text.partition("E" if upper else "e")
        # Keep the source's exponent spelling (E+09, E9, e-3): sign and digits as wide as it wrote them.
        digits = len(exp.lstrip("eE+-"))
        sign = "-" if power.startswith("-") else ("+" if "+" in exp else "")
        return f"{mantissa}{exp[0]}{sign}{power.lstrip('+-').lstrip('0').rjust(digits, '0') or '0'}"
    text = f"{value:.{places}f}"
    if text[0] == "-" and not text.strip("-0."):  # rounds to zero (a program's numbers: 60 000 of these calls)
        text = text[1:]
    if stripped.lstrip("+-").startswith(".") and text.lstrip("-").startswith("0."):  # `.4` stays without its 0
        text = text.replace("0.", ".", 1)
    if m is not None and stripped.startswith("+") and not text.startswith("-"):
        text = "+" + text
    return text


def parse_number(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text!r} is not a finite number")
    return value
