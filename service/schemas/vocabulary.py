"""What the service knows by name, for clients to read rather than copy: the pose-design criteria and the record
kinds a campaign may hold (each from its registry: `optimal_design.criteria.CRITERIA`,
`service.record_kinds.RECORD_KINDS`)."""

from __future__ import annotations

from pydantic import Field

from service.schemas.common import Public


class CriterionPublic(Public):
    name: str = Field(description="As a pose design's `criterion` takes it")
    summary: str = Field(description="What a design by it makes small")
    targetable: bool = Field(description="A design for a target accuracy may use it")
    branchable: bool = Field(description="Branch and bound (`bound_seconds`) can tighten its certificate")


class AdaptiveCriterionPublic(Public):
    name: str = Field(description="As an adaptive campaign's `criterion` takes it")
    summary: str = Field(description="What each next pose is chosen to improve most")
    default: bool = Field(description="What a campaign that names none uses")


class RecordKindPublic(Public):
    name: str = Field(description="A record's `kind` (a tracker's records name none: tracker)")
    measures: str = Field(description="What its records measure, as the report's references name it")
    named_by: str | None = Field(description="The record's field naming the reference it measures; null: none")
    described_in: str | None = Field(description="The body's map that describes those references; null: none")
    file_kinds: list[str] = Field(description="The values of a campaign file's `kind` column that mean it")
    designable: bool = Field(description="A pose design may plan its records (`measurement`)")
    sampled: bool = Field(description="A design may sample its candidate poses (else: give candidates)")
