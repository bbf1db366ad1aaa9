from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request, Response

from service.http.deps import Compute, ComputeDep, DatabaseDep, requested_media
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.security import Scope
from service.services import reports

router = APIRouter(tags=["reports"], route_class=OffloopRoute)
_FORMATS = {"html": "text/html", "pdf": "application/pdf"}
REPORT_RESPONSES: dict[int | str, dict[str, Any]] = {
    200: {
        "description": "The report: self-contained HTML (inline SVG figures) or PDF",
        "content": {
            "text/html": {"schema": {"type": "string"}},
            "application/pdf": {"schema": {"type": "string", "format": "binary"}},
        },
    },
    406: {"description": "Accept allows neither HTML nor PDF"},
}
"""The answers of a report route (`Report.answer`)."""
ReportFormat = Annotated[str | None, Query(pattern="^(html|pdf)$", description="Overrides Accept")]


@dataclass(frozen=True)
class Report:
    """A report the compute pool renders (as the metrics name it, `kind`) as self-contained HTML or as PDF, from
    the same keyword arguments; each renderer is a module-level function (it travels by reference)."""

    kind: str
    html: Callable[..., str]
    pdf: Callable[..., bytes]

    async def answer(
        self, compute: Compute, request: Request, format: str | None, name: str, **arguments: Any
    ) -> Response:
        """The report in the media type `?format=` or the Accept header asks for: PDF inline as `name`.pdf, or
        HTML."""
        if requested_media(request, format, _FORMATS) == "application/pdf":
            pdf = await compute(self.kind, self.pdf, **arguments)
            disposition = f'inline; filename="{name}.pdf"'
            return Response(pdf, media_type="application/pdf", headers={"Content-Disposition": disposition})
        page = await compute(self.kind, self.html, **arguments)
        return Response(page, media_type="text/html; charset=utf-8")


_CALIBRATION_REPORT = Report("report", reports.report_html, reports.report_pdf)


@router.get("/v1/calibrations/{calibration_id}/report", response_class=Response, responses=REPORT_RESPONSES)
@operation(Scope.read, runs=Runs.COMPUTE)
async def calibration_report(
    calibration_id: str, request: Request, db: DatabaseDep, compute: ComputeDep, format: ReportFormat = None
) -> Response:
    """Before/after errors per pose, histograms, the measured poses in 3-D, the variance-factor test, parameter
    changes with their std errors, the correlation heat map, outliers, validations of the version it produced,
    and the parameter table. Every number is the API's."""
    name = f"calibration-{calibration_id}"
    return await _CALIBRATION_REPORT.answer(compute, request, format, name, db=db, calibration_id=calibration_id)
