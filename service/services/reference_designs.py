"""Pose design against references (a ballbar's anchors, sockets, plates, cameras): the records to take, designed with
the robot's current parameters by `optimal_design.references`, reported as a tracker's design is, with the
reference each chosen record measures."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from models import RobotDescription
from models._types import Array
from models.engine.runtime import Runtime
from models.errors import TargetUnreachable
from models.measurement import MeasurementKind
from optimal_design import PoseDesign, TargetDesign
from optimal_design.references import DesignedOptions, design_reference_records, reference_records_for_target
from service.conversions.designs import design_noise, report_out, target_report_out
from service.conversions.reference_designs import ReferenceCandidates, reference_candidates_in, refuse_unsupported
from service.schemas.designs import PoseDesignCreate, PoseDesignReportPublic


def reference_report(
    desc: RobotDescription, theta: Array, body: PoseDesignCreate, runtime: Runtime
) -> PoseDesignReportPublic:
    """The report of a design of distance, point, plane or image records (count or target), as stored."""
    refuse_unsupported(body)
    found = reference_candidates_in(desc, theta, body, runtime)
    given = body.candidates is not None
    noise = design_noise(body)
    options = DesignedOptions(fixed=found.fixed, min_spread=body.min_spread, noise=noise, params=theta, runtime=runtime)
    if body.target is not None:
        target = _for_target(desc, body, found, options)
        names: list[str] = []
        if target.design is not None:  # None: the records already measured reach the target
            design, names = _as_offered(target.design, found)
            target = replace(target, design=design)
        # The core names the references' kinds; the report names what was asked (below).
        target = replace(target, measurement=MeasurementKind.POSITION.value)
        report = target_report_out(desc, target, candidates_given=given, criterion=body.criterion)
    else:
        assert body.count is not None  # the schema asks for count or target
        chosen = design_reference_records(
            desc,
            found.groups,
            body.count,
            body.criterion,
            seed=body.seed,
            d_efficiency_floor=body.d_efficiency_floor,
            bound_seconds=body.bound_seconds,
            **options,
        )
        design, names = _as_offered(chosen, found)
        report = report_out(desc, design, candidates_given=given)
    # The core designs position rows (its `measurement` would read "position"): the report names what was asked.
    return PoseDesignReportPublic.model_validate(
        {**report.model_dump(), "measurement": body.measurement, "references": names}
    )


def _for_target(
    desc: RobotDescription, body: PoseDesignCreate, found: ReferenceCandidates, options: DesignedOptions
) -> TargetDesign:
    """The target mode on the reference candidates; an unreachable target said in the records' words (the
    core's advice to measure the full pose is a tracker's)."""
    assert body.target is not None
    try:
        return reference_records_for_target(
            desc,
            found.groups,
            rms_tcp_mm=body.target.rms_tcp_mm,
            max_tcp_mm=body.target.max_tcp_mm,
            criterion=body.criterion,
            seed=body.seed,
            **options,
        )
    except TargetUnreachable as exc:
        raise TargetUnreachable(
            f"no selection of the {exc.candidates} candidate records reaches a predicted TCP error of "
            f"{exc.target_mm:g} mm: taking every one of them gives {exc.reachable_mm:.4g} mm, the best reachable; add "
            "candidates (more poses, another anchor or camera across the volume), give the instrument's σ (noise, a "
            "camera's sigma_px), or relax the target",
            field=str(exc.field),
            target_mm=exc.target_mm,
            reachable_mm=exc.reachable_mm,
            candidates=exc.candidates,
        ) from exc


def _as_offered(design: PoseDesign, found: ReferenceCandidates) -> tuple[PoseDesign, list[str]]:
    """The design with its indices into the candidates as the request gave (or sampled) them and the filters the
    service applied before the core saw them; and each chosen record's reference."""
    chosen = np.asarray(design.indices, dtype=np.intp)
    names = [found.names[i] for i in chosen]
    constraints = {**design.constraints, "offered": found.offered, "excluded": dict(found.excluded)}
    indices = tuple(int(i) for i in found.origin[chosen])
    return replace(design, indices=indices, constraints=constraints), names
