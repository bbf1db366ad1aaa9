"""Pose designs: the frozen `PoseDesign` as the report."""

from __future__ import annotations

from typing import Any

from models import RobotDescription
from optimal_design import PoseDesign
from service.conversions.kinematics import joints_out
from service.persistence.tables import PoseDesignRecord
from service.schemas.common import timestamp
from service.schemas.designs import PoseDesignReportPublic


def report_out(desc: RobotDescription, design: PoseDesign, *, candidates_given: bool) -> PoseDesignReportPublic:
    """`indices` point into the caller's candidates; sampled candidates are nobody's list, so null then."""
    return PoseDesignReportPublic.model_validate(
        {
            "criterion": design.criterion,
            "measurement": "position" if design.position_only else "pose",
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
        }
    )


def design_public(record: PoseDesignRecord) -> dict[str, Any]:
    """The stored report (validated when built) with the row's columns: a `PoseDesignPublic`, as JSON."""
    return {**record.result, "id": record.id, "robot_id": record.robot_id, "created_at": timestamp(record.created_at)}
