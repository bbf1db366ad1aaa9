"""The conversions build, from the domain's fields, what clients always received: the error analysis compared
with the command line's JSON export (built apart).

Also: schema defaults and enums are the domain's own."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest

from models import iwr
from models.error_analysis import DISTRIBUTIONS, ErrorMagnitudes, error_analysis
from models.error_analysis.export import result_json
from models.identification import IdentificationOptions
from models.identification.options import DEFAULT_GROUPS
from models.noise import NoiseModel
from optimal_design.criteria import Criterion
from optimal_design.design import MAX_CANDIDATES
from service.conversions import calibrations
from service.conversions import error_analysis as analysis
from service.schemas.calibrations import CalibrationCreate
from service.schemas.designs import PoseDesignCreate
from service.schemas.error_analysis import Distribution, ErrorAnalysisRequest

DESC = iwr()


def _json(value: Any) -> Any:
    """What the service used to send: to_dict's output with NaN and infinities as null."""

    def strict(v: Any) -> Any:
        if isinstance(v, float):
            return v if math.isfinite(v) else None
        if isinstance(v, dict):
            return {k: strict(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [strict(x) for x in v]
        return v

    return json.loads(json.dumps(strict(value)))


def test_error_analysis_report_equals_the_old_payload() -> None:
    """The service's answer and the command line's JSON file are built apart; they must agree."""
    result = error_analysis(DESC, n_poses=3, n_draws=5, seed=2)
    assert analysis.report_out(result).model_dump(mode="json") == _json(result_json(result))


def test_schema_defaults_and_enums_are_the_domain_s() -> None:
    body = CalibrationCreate.model_validate({"measurements": [{"joints": [0] * 10, "position": [0, 0, 0]}]})
    options = calibrations.options_in(body)
    assert options == IdentificationOptions(estimate=DEFAULT_GROUPS)
    noise = calibrations.noise_in(body)
    assert noise.position_mm == NoiseModel().position_mm
    assert noise.orientation_rad == pytest.approx(NoiseModel().orientation_rad, rel=1e-12)
    design = PoseDesignCreate(count=3)
    assert design.criterion is Criterion.D
    properties = PoseDesignCreate.model_json_schema()["properties"]
    assert properties["candidate_count"]["maximum"] == MAX_CANDIDATES
    assert analysis.tolerances_in(ErrorAnalysisRequest()) == ErrorMagnitudes()
    assert set(Distribution.__args__) == set(DISTRIBUTIONS)  # type: ignore[attr-defined]
