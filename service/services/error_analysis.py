from __future__ import annotations

import numpy as np

from models import Registry, iwr
from models.error_analysis import error_analysis
from models.errors import InvalidInput
from service.compute.model_cache import ModelCache
from service.conversions.error_analysis import report_out, tolerances_in
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest


def analyse(*, registry: Registry, body: ErrorAnalysisRequest, models: ModelCache) -> ErrorAnalysisPublic:
    """The thesis's tolerance study on a robot's nominal description (any structure; the IWR when the body names
    no robot); nothing is stored."""
    # The description's nominal geometry, not a calibrated version: tolerances are about how the robot is built.
    desc = iwr() if body.robot_id is None else models.current(body.robot_id)[0]
    try:
        result = error_analysis(
            desc,
            n_poses=body.poses,
            n_draws=body.draws,
            tolerances=tolerances_in(body),
            distribution=body.distribution,
            seed=body.seed,
            runtime=registry.runtime(desc),
        )
    except np.linalg.LinAlgError as exc:
        # Found by schemathesis (leg_offset_mm=89, "sign"): tolerances that large leave the perturbed hexapod's
        # forward kinematics non-finite, and the assembly check's eigenvalues fail inside numpy. The cause
        # belongs to models.kinematics (a non-finite platform should be an UnreachablePose there); until then
        # the caller gets what it is: tolerances the robot cannot be assembled with.
        raise InvalidInput(
            f"tolerances this large leave perturbed robots that cannot be assembled ({exc})", field="tolerances"
        ) from exc
    return report_out(result)
