"""The one error of file import: the sender's file, named by line and column (a 400 problem)."""

from __future__ import annotations

from typing import Any

from service.problems import BadRequest


class CampaignFileError(BadRequest):
    """A campaign file that cannot be read as given; `line` and `column` (1-based) say where, when known."""

    def __init__(self, detail: str, *, line: int | None = None, column: int | None = None, **data: Any) -> None:
        found = {"line": line, "column": column, **data}
        super().__init__(detail, **{k: v for k, v in found.items() if v is not None})
