"""The one error of file import: the sender's file, named by line and column (a 400 problem)."""

from __future__ import annotations

from collections.abc import Sequence

from service.errors import BadRequest


class CampaignFileError(BadRequest):
    """A campaign file that cannot be read as given; `line` and `column` (1-based) say where, when known."""


SHOWN = 20
"""Names a message lists at most: a header of 20 000 columns once came back as a 150 kB problem document."""


def listed(names: Sequence[str]) -> str:
    """`a, b, c`, or the first SHOWN names and how many there are in all."""
    if len(names) <= SHOWN:
        return ", ".join(names)
    return ", ".join(names[:SHOWN]) + f", … ({len(names)} in all)"
