"""The thesis's tolerance study (§4.5): how far manufacturing errors move the TCP.

- `magnitudes`: `ErrorMagnitudes`, the four error sizes (also what `models.simulation` perturbs by);
- `study`: pose errors of perturbed robots, the draws, the worst cases, `error_analysis` itself;
- `result`: `ErrorAnalysisResult` and the shares derived from it;
- `statistics`: per-axis and absolute statistics in boundary units;
- `report`: `summary`, the text report;
- `plot`: the figures (matplotlib, imported when a figure is drawn);
- `__main__`: the command line, `python -m models.error_analysis`.

The study never imports the plots or the command line; they import it.
"""

from models.error_analysis.magnitudes import ErrorMagnitudes
from models.error_analysis.report import summary
from models.error_analysis.result import MODELS, NEGLIGIBLE, SUBSYSTEMS, ErrorAnalysisResult, PoseErrors, WorstCase
from models.error_analysis.statistics import AXES
from models.error_analysis.study import (
    DISTRIBUTIONS,
    MAX_DRAWS,
    MAX_EVALUATIONS,
    MAX_POSES,
    carriage_frame_errors,
    draw_errors,
    error_analysis,
    pose_errors,
    subsystem_mask,
)

__all__ = [
    "AXES",
    "DISTRIBUTIONS",
    "MAX_DRAWS",
    "MAX_EVALUATIONS",
    "MAX_POSES",
    "MODELS",
    "NEGLIGIBLE",
    "SUBSYSTEMS",
    "ErrorAnalysisResult",
    "ErrorMagnitudes",
    "PoseErrors",
    "WorstCase",
    "carriage_frame_errors",
    "draw_errors",
    "error_analysis",
    "pose_errors",
    "subsystem_mask",
    "summary",
]
