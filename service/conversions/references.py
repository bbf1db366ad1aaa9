"""A campaign of reference records (and tracker positions beside them) as the models' record groups, and the
identified references as the report states them (boundary units: mm, deg)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from models import RobotDescription
from models.identification.result import ReferenceEstimate
from models.measurements.camera import Camera, read_images
from models.measurements.references import Anchor, FixedPoint, Plane, ReferenceRecords, TrackerPositions
from models.parameters import Kind
from models.transforms import matrix_to_rotvec_np
from service.conversions.kinematics import joints_in
from service.errors import BadRequest
from service.schemas.calibrations import CampaignRecord, Record
from service.schemas.references import (
    AnchorDescription,
    CameraDescription,
    DistanceRecord,
    ImageRecord,
    PlaneDescription,
    PlaneRecord,
    PointDescription,
    PointRecord,
)

DEFAULT_PLANE_SIDE = (0.0, 0.0, 1.0)
"""The side a plane is taken to be touched from when its description gives none (the fit's sign only)."""


def has_references(measurements: Sequence[CampaignRecord]) -> bool:
    """Whether a campaign holds any record of the instruments a cell owns (not only a tracker's)."""
    return any(not isinstance(r, Record) for r in measurements)


@dataclass(frozen=True)
class Described:
    """The references a body describes (its `anchors`, `points`, `planes`)."""

    anchors: Mapping[str, AnchorDescription]
    points: Mapping[str, PointDescription]
    planes: Mapping[str, PlaneDescription]
    cameras: Mapping[str, CameraDescription] = field(default_factory=dict)


def reference_groups_in(
    desc: RobotDescription, measurements: Sequence[CampaignRecord], described: Described, *, sigma_mm: float
) -> tuple[tuple[ReferenceRecords, ...], list[str]]:
    """The records grouped by the reference they measure (internal units), each record keeping its place in
    the campaign (`sigma_mm`: a record's σ where it states none); and the notes the conversion makes. A record
    that names an undescribed anchor, a description no record uses: a 4xx naming it."""
    by_reference: dict[tuple[str, str], list[int]] = {}
    for i, record in enumerate(measurements):
        by_reference.setdefault(_reference_of(record), []).append(i)
    _check_descriptions(described, by_reference)
    notes: list[str] = []
    groups = []
    for (kind, name), index in by_reference.items():
        records = [measurements[i] for i in index]
        if kind == "image":
            groups.append(_images(desc, name, described.cameras[name], records, index))
            continue
        joints = joints_in(desc, [r.joints for r in records])
        sigma = _sigmas(records, sigma_mm)
        positions = np.asarray(index, dtype=np.intp)
        groups.append(ReferenceRecords(_reference(described, kind, name), joints, _values(records), sigma, positions))
        if kind == "tracker" and any(isinstance(r, Record) and r.orientation is not None for r in records):
            notes.append(
                "the tracker records' orientations are not used beside distance, point or plane records: their "
                "positions fix the frame"
            )
    return tuple(groups), notes


def _reference_of(record: CampaignRecord) -> tuple[str, str]:
    if isinstance(record, DistanceRecord):
        return "anchor", record.anchor
    if isinstance(record, PointRecord):
        return "point", record.point
    if isinstance(record, PlaneRecord):
        return "plane", record.plane
    if isinstance(record, ImageRecord):
        return "image", record.camera
    return "tracker", "tracker"


def _check_descriptions(body: Described, used: dict[tuple[str, str], list[int]]) -> None:
    for (kind, name), index in used.items():
        if kind == "anchor" and name not in body.anchors:
            raise BadRequest(
                f"record {index[0]} measures anchor {name!r}, which the campaign does not describe: add "
                f'"anchors": {{"{name}": {{}}}} (with "length_unknown": true for a ballbar whose length offset is '
                "not known)",
                record=index[0],
            )
        if kind == "image" and name not in body.cameras:
            raise BadRequest(
                f"record {index[0]} is an image of camera {name!r}, which the campaign does not describe: add "
                f'"cameras": {{"{name}": {{"fx": …, "fy": …, "cx": …, "cy": …, "mount": "world"}}}} (its '
                "intrinsics in px)",
                record=index[0],
            )
    described_kinds = (("anchor", body.anchors), ("point", body.points), ("plane", body.planes))
    for kind, described in (*described_kinds, ("image", body.cameras)):
        for name in described:
            if (kind, name) not in used:
                raise BadRequest(
                    f"{kind} {name!r} is described but no record measures it: remove it, or check the records' "
                    f"{kind} names ({sorted(n for k, n in used if k == kind) or 'none'})"
                )


def _reference(body: Described, kind: str, name: str) -> Anchor | FixedPoint | Plane | TrackerPositions:
    """The reference with its description's guesses (the fit computes its start from the records)."""
    if kind == "anchor":
        anchor = body.anchors[name]
        x, y, z = anchor.position_mm or (0.0, 0.0, 0.0)
        return Anchor(name, (x, y, z), length_unknown=anchor.length_unknown)
    if kind == "point":
        point = body.points.get(name)
        px, py, pz = (point.position_mm if point else None) or (0.0, 0.0, 0.0)
        return FixedPoint(name, (px, py, pz))
    if kind == "plane":
        plane = body.planes.get(name)
        nx, ny, nz = (plane.normal if plane else None) or DEFAULT_PLANE_SIDE
        if math.hypot(nx, ny, nz) == 0.0:
            raise BadRequest(f"plane {name!r}: its normal is the zero vector; give the side it is touched from")
        return Plane(name, (nx, ny, nz), 0.0)
    return TrackerPositions()


def _images(
    desc: RobotDescription,
    name: str,
    camera: CameraDescription,
    records: Sequence[CampaignRecord],
    index: Sequence[int],
) -> ReferenceRecords:
    """One camera's images as its records, one a seen point, each named by its image's place in the campaign."""
    images = [
        {
            "camera": name,
            "joints": q,
            "points": [p.model_dump() for p in r.points],
            **({"sigma_px": r.sigma_px} if r.sigma_px is not None else {}),
        }
        for r, q in zip(
            (r for r in records if isinstance(r, ImageRecord)),
            joints_in(desc, [r.joints for r in records]),
            strict=True,
        )
    ]
    [group] = read_images({name: camera.model_dump(exclude_none=True)}, images)
    image = group.values[:, 0].astype(int)
    values = group.values.copy()
    values[:, 0] = np.asarray(index)[image]  # messages name the image as the campaign does
    return ReferenceRecords(group.reference, group.joints, values, group.sigma_mm, np.asarray(index)[image])


def _values(records: Sequence[CampaignRecord]) -> np.ndarray:
    """What each record measured: a distance (mm), a tracker position (mm), nothing for a touch."""
    first = records[0]
    if isinstance(first, DistanceRecord):
        return np.array([r.distance_mm for r in records if isinstance(r, DistanceRecord)], dtype=float)
    if isinstance(first, Record):
        return np.array([r.position for r in records if isinstance(r, Record)], dtype=float)
    return np.zeros(len(records))


def _sigmas(records: Sequence[CampaignRecord], default_mm: float) -> np.ndarray | None:
    given = [getattr(r, "sigma_mm", None) for r in records]  # an image's σ is in px: its own group (`_images`)
    if all(g is None for g in given):
        return None
    return np.array([default_mm if g is None else g for g in given], dtype=float)


def references_out(estimates: Sequence[ReferenceEstimate]) -> list[dict[str, Any]]:
    """Each identified reference as `ReferencePublic`: its unknowns in boundary units, and what they mean."""
    out = []
    for estimate in estimates:
        ref = estimate.reference
        specs = ref.unknowns
        unknowns = [
            {
                "name": spec.name,
                "value": _boundary(spec.kind, float(v)),
                "std_error": _boundary(spec.kind, float(s)) if np.isfinite(s) else None,
                "unit": "deg" if spec.kind is Kind.ANGLE else "mm",
            }
            for spec, v, s in zip(specs, estimate.values, estimate.std_errors, strict=True)
        ]
        entry: dict[str, Any] = {
            "kind": ref.traits.kind,
            "name": ref.name,
            "records": estimate.records,
            "rms_residual_mm": estimate.rms_residual_mm,
            "unknowns": unknowns,
        }
        if isinstance(ref, Anchor | FixedPoint):
            entry["position_mm"] = [float(v) for v in estimate.values[:3]]
        if isinstance(ref, Anchor) and ref.length_unknown:
            entry["length_offset_mm"] = float(estimate.values[3])
        if isinstance(ref, Plane):
            normal, _, _ = ref.normal_at(float(estimate.values[0]), float(estimate.values[1]))
            entry["normal"] = [float(v) for v in normal]
            entry["offset_mm"] = float(estimate.values[2])
        if isinstance(ref, Camera):
            # The unknowns turn the start orientation; the report states the orientation itself.
            entry["position_mm"] = [float(v) for v in estimate.values[:3]]
            turned = matrix_to_rotvec_np(ref.orientation(estimate.values[3:6]))
            entry["rotation_vector_deg"] = [float(v) * Kind.ANGLE.to_boundary for v in turned]
        out.append(entry)
    return out


def _boundary(kind: Kind, value: float) -> float:
    return value * kind.to_boundary  # the parameters' own factor: mm stay mm, rad become deg
