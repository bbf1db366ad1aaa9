"""What the service knows by name: clients list these instead of keeping their own copies."""

from __future__ import annotations

from fastapi import APIRouter, Response

from service.http.operations import operation
from service.http.responses import models_json
from service.http.security import Scope
from service.schemas.vocabulary import AdaptiveCriterionPublic, CriterionPublic, RecordKindPublic
from service.services import vocabulary

router = APIRouter(tags=["vocabulary"])


@router.get("/v1/design-criteria", response_model=list[CriterionPublic])
@operation(Scope.read)
def design_criteria() -> Response:
    """Every pose-design criterion, in the order messages list them."""
    return models_json(vocabulary.design_criteria(), CriterionPublic)


@router.get("/v1/adaptive-criteria", response_model=list[AdaptiveCriterionPublic])
@operation(Scope.read)
def adaptive_criteria() -> Response:
    """Every criterion an adaptive campaign may choose its next pose by, the default marked."""
    return models_json(vocabulary.adaptive_criteria(), AdaptiveCriterionPublic)


@router.get("/v1/record-kinds", response_model=list[RecordKindPublic])
@operation(Scope.read)
def record_kinds() -> Response:
    """Every kind of record a campaign may hold (a tracker's first), and what a pose design can do with it."""
    return models_json(vocabulary.record_kinds(), RecordKindPublic)
