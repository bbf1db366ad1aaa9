"""Pose designs: the frozen `PoseDesign` as the report."""

from __future__ import annotations

from typing import Any

from models import NoiseModel, RobotDescription
from models.errors import InvalidInput
from models.measurement import MeasurementKind
from optimal_design import PoseDesign, TargetDesign
from optimal_design.criteria import Criterion
from service.conversions.kinematics import joints_out
from service.conversions.units import instrument_noise
from service.persistence.tables import PoseDesignRecord
from service.schemas.common import timestamp
from service.schemas.designs import (
    KeepOutBox,
    PoseDesignCreate,
    PoseDesignPublic,
    PoseDesignReportPublic,
    PoseDesignSummaryPublic,
)


def report_out(desc: RobotDescription, design: PoseDesign, *, candidates_given: bool) -> PoseDesignReportPublic:
    """`indices` point into the caller's candidates; sampled candidates are nobody's list, so null then."""
    return PoseDesignReportPublic.model_validate(
        {
            "criterion": design.criterion,
            "measurement": MeasurementKind.of(design.position_only).value,
            "count": len(design.indices),
            "poses": joints_out(desc, design.joints),
            "indices": list(design.indices) if candidates_given else None,
            "value": design.value,
            "metrics": design.metrics,
            "random_baseline": design.random_baseline,
            "greedy": design.greedy,
            "bound": design.bound,
            "efficiency": design.efficiency,
            "relaxation": design.relaxation,
            "identifiable": list(design.identifiable),
            "candidates": design.candidates,
            "fixed": design.fixed,
            "seconds": design.seconds,
            "notes": list(design.notes),
            "constraints": design.constraints,
            **_conditions_out(design),
        }
    )


def _conditions_out(design: PoseDesign) -> dict[str, Any]:
    """The chosen poses' temperatures and payloads, where the design had levels to choose from."""
    c = design.conditions
    if c is None:
        return {}
    return {
        "temperature_c": None if c.temperature_c is None else c.temperature_c.tolist(),
        "payload_kg": None if c.payload_kg is None else c.payload_kg.tolist(),
    }


def target_report_out(
    desc: RobotDescription, found: TargetDesign, *, candidates_given: bool, criterion: Criterion
) -> PoseDesignReportPublic:
    """Target mode: the design at the smallest K (when any pose is needed) with the curve of error against K."""
    extra = {
        "target": found.target,
        "curve": [dict(point) for point in found.curve],
        "reachable_mm": found.reachable_mm,
        "fixed_mm": found.fixed_mm,
    }
    if found.design is not None:
        report = report_out(desc, found.design, candidates_given=candidates_given).model_dump()
        notes = [*report["notes"], *found.notes]
        return PoseDesignReportPublic.model_validate({**report, **extra, "notes": notes, "count": found.count})
    return PoseDesignReportPublic.model_validate(
        {
            "criterion": criterion,
            "measurement": MeasurementKind.of(found.measurement).value,  # what was asked for; no pose is needed
            "count": 0,
            "poses": [],
            "indices": [] if candidates_given else None,
            "value": None,
            "metrics": None,
            "random_baseline": None,
            "greedy": None,
            "bound": None,
            "efficiency": None,
            "relaxation": None,
            "identifiable": [],
            "candidates": 0,
            "fixed": 0,
            "seconds": found.seconds,
            "notes": list(found.notes),
            "constraints": None,
            **extra,
        }
    )


def design_noise(body: PoseDesignCreate) -> NoiseModel | None:
    """The instrument's σ the predictions are for, internal units; None: the models' default."""
    if body.noise is None:
        return None
    return instrument_noise(body.noise.position_mm, body.noise.orientation_deg)


def constraints_in(
    desc: RobotDescription, body: PoseDesignCreate
) -> tuple[dict[int, tuple[float, float]] | None, tuple[list[float], list[float]] | None]:
    """Joint sub-ranges by name in boundary units → by index in internal units; the keep-out box (mm)."""
    ranges: dict[int, tuple[float, float]] | None = None
    if body.joint_ranges is not None:
        ranges = {}
        names = list(desc.joint_names)
        for name, (lo, hi) in body.joint_ranges.items():
            if name not in names:
                raise InvalidInput(
                    f"joint_ranges: {name!r} is not a joint of this robot ({', '.join(names)})",
                    field="joint_ranges",
                    value=name,
                    allowed=names,
                )
            k = names.index(name)
            scale = float(desc.joint_to_boundary[k])
            ranges[k] = (lo / scale, hi / scale)
    box: KeepOutBox | None = body.keep_out
    keep_out = None if box is None else (list(box.lower), list(box.upper))
    return ranges, keep_out


def _document(record: PoseDesignRecord) -> dict[str, Any]:
    """The stored report with the row's columns."""
    return {**record.result, "id": record.id, "robot_id": record.robot_id, "created_at": timestamp(record.created_at)}


def design_public(record: PoseDesignRecord) -> PoseDesignPublic:
    return PoseDesignPublic.model_validate(_document(record))


def design_summary(record: PoseDesignRecord) -> PoseDesignSummaryPublic:
    """Its line in a robot's list, validated from the stored keys it shows (a page of designs need not validate
    every design's poses)."""
    document = _document(record)
    return PoseDesignSummaryPublic.model_validate(
        {k: document[k] for k in PoseDesignSummaryPublic.model_fields if k in document}
    )
