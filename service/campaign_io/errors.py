"""The one error of file import: the sender's file, named by line and column (a 400 problem)."""

from __future__ import annotations

from service.errors import BadRequest


class CampaignFileError(BadRequest):
    """A campaign file that cannot be read as given; `line` and `column` (1-based) say where, when known."""
