from __future__ import annotations

from models import iwr
from models.error_analysis import error_analysis
from service.conversions.error_analysis import report_out, tolerances_in
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest


def analyse(*, body: ErrorAnalysisRequest) -> ErrorAnalysisPublic:
    """The thesis's tolerance study on the nominal IWR; nothing is stored."""
    result = error_analysis(
        iwr(),
        n_poses=body.poses,
        n_draws=body.draws,
        tolerances=tolerances_in(body),
        distribution=body.distribution,
        seed=body.seed,
    )
    return report_out(result)
