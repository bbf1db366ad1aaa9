"""The registries' entries in their public form (`GET /v1/design-criteria`, `GET /v1/adaptive-criteria`,
`GET /v1/record-kinds`)."""

from __future__ import annotations

from optimal_design.adaptive_scores import ADAPTIVE_SUMMARIES
from optimal_design.criteria import CRITERIA
from service.record_kinds import RECORD_KINDS
from service.schemas.adaptive import AdaptiveCampaignCreate
from service.schemas.vocabulary import AdaptiveCriterionPublic, CriterionPublic, RecordKindPublic


def design_criteria() -> list[CriterionPublic]:
    return [
        CriterionPublic(name=c.name.value, summary=c.summary, targetable=c.targetable, branchable=c.branchable)
        for c in CRITERIA.values()
    ]


def adaptive_criteria() -> list[AdaptiveCriterionPublic]:
    default = AdaptiveCampaignCreate.model_fields["criterion"].default
    return [
        AdaptiveCriterionPublic(name=c.value, summary=summary, default=c is default)
        for c, summary in ADAPTIVE_SUMMARIES.items()
    ]


def record_kinds() -> list[RecordKindPublic]:
    return [
        RecordKindPublic(
            name=name,
            measures=kind.model,
            named_by=kind.named_by,
            described_in=kind.described_in,
            file_kinds=[k for k in kind.file_kinds if k],
            designable=kind.designable,
            sampled=kind.sampled,
        )
        for name, kind in RECORD_KINDS.items()
    ]
