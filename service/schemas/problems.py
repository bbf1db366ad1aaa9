"""The RFC 9457 problem document every error answers with (and a failed job stores)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from service.schemas.common import Public


class ValidationIssuePublic(Public):
    loc: list[str | int] = Field(description="Where: e.g. ['body', 'joints', 0]")
    field: str = Field(
        description="The same place as the specs name fields: `joints[0]`; in a robot's description document its "
        "own path, `stages[0].links[0].joint`"
    )
    msg: str


class Problem(BaseModel):
    """RFC 9457 problem document; more members may carry data about the error.

    The extension members (which pose, which joint, which value and limit) depend on the error's `type`:
    RFC 9457 leaves them open, so this is the one response object that allows keys it does not list."""

    model_config = ConfigDict(extra="allow")
    type: str = Field(description="https://iwr-calibration.example/problems/<slug>")
    title: str
    status: int
    detail: str = Field(description="What to fix")
    errors: list[ValidationIssuePublic] | None = Field(
        default=None, exclude_if=lambda v: v is None, description="A validation error's list of what and where"
    )
