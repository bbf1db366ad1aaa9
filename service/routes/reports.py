from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request, Response

from service.http.deps import ComputeDep, DatabaseDep, negotiate
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.security import Scope
from service.services import reports

router = APIRouter(tags=["reports"], route_class=OffloopRoute)
_FORMATS = {"html": "text/html", "pdf": "application/pdf"}
_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {
        "description": "The report: self-contained HTML (inline SVG figures) or PDF",
        "content": {
            "text/html": {"schema": {"type": "string"}},
            "application/pdf": {"schema": {"type": "string", "format": "binary"}},
        },
    },
    406: {"description": "Accept allows neither HTML nor PDF"},
}


@router.get("/v1/calibrations/{calibration_id}/report", response_class=Response, responses=_RESPONSES)
@operation(Scope.read, runs=Runs.COMPUTE)
async def calibration_report(
    calibration_id: str,
    request: Request,
    db: DatabaseDep,
    compute: ComputeDep,
    format: str | None = Query(None, pattern="^(html|pdf)$", description="Overrides Accept"),
) -> Response:
    """Before/after errors per pose, histograms, the measured poses in 3-D, the variance-factor test, parameter
    changes with their std errors, the correlation heat map, outliers, validations of the version it produced,
    and the parameter table. Every number is the API's."""
    media = _FORMATS[format] if format else negotiate(request, list(_FORMATS.values()))
    if media == "application/pdf":
        pdf = await compute("report", reports.report_pdf, db=db, calibration_id=calibration_id)
        disposition = f'inline; filename="calibration-{calibration_id}.pdf"'
        return Response(pdf, media_type="application/pdf", headers={"Content-Disposition": disposition})
    page = await compute("report", reports.report_html, db=db, calibration_id=calibration_id)
    return Response(page, media_type="text/html; charset=utf-8")
