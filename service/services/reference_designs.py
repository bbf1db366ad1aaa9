"""Pose design against references (a ballbar's anchors, sockets, plates, cameras): the candidate records of a
request as the design problem of `optimal_design.references` (the records already measured its base), and how
its designs are said in the request's words: indices into the candidates as given, the reference each chosen
record measures, an unreachable target in the records' words. `service.services.designs` solves and reports it
as it does a tracker's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from models import NoiseModel, RobotDescription
from models._types import Array
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime
from models.errors import TargetUnreachable
from optimal_design import PoseDesign
from optimal_design.problem import DesignProblem
from optimal_design.references import reference_design_problem
from service.conversions.reference_designs import ReferenceCandidates, reference_candidates_in
from service.schemas.designs import PoseDesignCreate


def reference_problem_of(
    desc: RobotDescription, theta: Array, body: PoseDesignCreate, runtime: Runtime, noise: NoiseModel | None
) -> tuple[DesignProblem, ReferenceCandidates]:
    """The design problem of a request's distance, point, plane, image or displacement records, and the
    candidates it was built from (what `as_offered` maps its designs back to)."""
    found = reference_candidates_in(desc, theta, body, runtime)
    # Built with one BLAS thread, as the design that follows and the library's entry points are.
    problem = single_threaded_blas(reference_design_problem)(
        desc,
        found.groups,
        fixed=found.fixed,
        min_spread=body.min_spread,
        noise=noise,
        params=theta,
        runtime=runtime,
    )
    return problem, found


def in_records_words(exc: TargetUnreachable) -> TargetUnreachable:
    """An unreachable target said in the records' words (the core's advice to measure the full pose is a
    tracker's)."""
    return TargetUnreachable(
        f"no selection of the {exc.candidates} candidate records reaches a predicted TCP error of "
        f"{exc.target_mm:g} mm: taking every one of them gives {exc.reachable_mm:.4g} mm, the best reachable; add "
        "candidates (more poses, another anchor or camera across the volume), give the instrument's σ (noise, a "
        "camera's sigma_px), or relax the target",
        field=str(exc.field),
        target_mm=exc.target_mm,
        reachable_mm=exc.reachable_mm,
        candidates=exc.candidates,
    )


def as_offered(design: PoseDesign, found: ReferenceCandidates) -> tuple[PoseDesign, list[str]]:
    """The design with its indices into the candidates as the request gave (or sampled) them and the filters the
    service applied before the core saw them; and each chosen record's reference."""
    chosen = np.asarray(design.indices, dtype=np.intp)
    names = [found.names[i] for i in chosen]
    constraints = {**design.constraints, "offered": found.offered, "excluded": dict(found.excluded)}
    indices = tuple(int(i) for i in found.origin[chosen])
    return replace(design, indices=indices, constraints=constraints), names
