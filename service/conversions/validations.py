"""Validations: a domain `AccuracyReport` per version as the response, and the ISO cube poses."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models import RobotDescription
from models.evaluation.accuracy import AccuracyReport, CubePoses
from service.persistence.tables import CheckRecord, ValidationRecord
from service.schemas.common import timestamp
from service.schemas.validations import IsoPosesPublic, ValidationPublic, VersionResultPublic


def _deg(values: Any) -> list[float]:
    return [math.degrees(float(v)) for v in values]


def version_result_out(desc: RobotDescription, version: int, report: AccuracyReport) -> VersionResultPublic:
    per_pose_deg = None if report.orientation_rad is None else np.degrees(report.orientation_rad).tolist()
    percentiles = report.percentiles_mm()
    result: dict[str, Any] = {
        "version": version,
        "registered": report.registered,
        "position_mm": {
            "rms": report.rms_mm,
            "max": report.max_mm,
            "percentiles": {f"p{int(p)}": v for p, v in percentiles.items()},
        },
        "per_pose": [
            {"position_mm": float(e), "orientation_deg": None if per_pose_deg is None else per_pose_deg[i]}
            for i, e in enumerate(report.position_mm)
        ],
    }
    if report.rms_rad is not None and report.max_rad is not None:
        result["orientation_deg"] = {"rms": math.degrees(report.rms_rad), "max": math.degrees(report.max_rad)}
    if report.iso_poses:
        scale = desc.joint_to_boundary
        poses = []
        for pose in report.iso_poses:
            c = pose.characteristics
            poses.append(
                {
                    "joints": (pose.joints * scale).tolist(),
                    "cycles": c.cycles,
                    "records": list(pose.records),
                    "commanded_mm": c.commanded_position.tolist(),
                    "barycentre_mm": c.barycentre.tolist(),
                    "AP_mm": c.accuracy_mm,
                    "AP_xyz_mm": c.accuracy_xyz_mm.tolist(),
                    "RP_mm": c.repeatability_mm,
                    "AP_abc_deg": None if c.orientation_accuracy_rad is None else _deg(c.orientation_accuracy_rad),
                    "RP_abc_deg": None
                    if c.orientation_repeatability_rad is None
                    else _deg(c.orientation_repeatability_rad),
                }
            )
        distances = [
            {
                "poses": list(d.poses),
                "cycles": d.characteristics.cycles,
                "commanded_mm": d.characteristics.commanded_mm,
                "mean_attained_mm": d.characteristics.mean_attained_mm,
                "AD_mm": d.characteristics.accuracy_mm,
                "RD_mm": d.characteristics.repeatability_mm,
            }
            for d in report.iso_distances
        ]
        result["iso9283"] = {"poses": poses, "distances": distances}
    return VersionResultPublic.model_validate(result)


def measured_document(record: ValidationRecord | CheckRecord) -> dict[str, Any]:
    """A stored validation's or check's document with the row's own columns: measurements of a campaign
    evaluated, never fitted, stored alike."""
    return {
        **record.result,
        "id": record.id,
        "robot_id": record.robot_id,
        "campaign_id": record.campaign_id,
        "created_at": timestamp(record.created_at),
        "notes": record.notes,
        "instrument": record.instrument,
    }


def validation_public(record: ValidationRecord) -> ValidationPublic:
    return ValidationPublic.model_validate(measured_document(record))


def iso_poses_out(desc: RobotDescription, robot_id: str, version: int, cube: CubePoses) -> IsoPosesPublic:
    scale = desc.joint_to_boundary
    return IsoPosesPublic.model_validate(
        {
            "robot_id": robot_id,
            "version": version,
            "edge_mm": cube.cube.edge_mm,
            "centre_mm": cube.cube.centre.tolist(),
            "orientation": cube.orientation.tolist(),
            "corners": [{"name": f"C{i + 1}", "position": p.tolist()} for i, p in enumerate(cube.cube.corners)],
            "poses": [
                {"name": f"P{i + 1}", "position": p.tolist(), "joints": (q * scale).tolist()}
                for i, (p, q) in enumerate(zip(cube.cube.points, cube.joints, strict=True))
            ],
        }
    )
