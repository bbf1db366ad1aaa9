"""A campaign of reference records (and tracker positions beside them) as the models' record groups, and the
identified references as the report states them (boundary units: mm, deg). What each kind of record contributes
is its kind's (`service.record_kinds`); `Described` and `described` are re-exported from there for the callers that
import them here."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from models import RobotDescription
from models.description.parameters import Kind
from models.identification.result import ReferenceEstimate
from models.measurements.references import ReferenceRecords
from service.errors import BadRequest
from service.record_kinds import (
    BY_MODEL,
    RECORD_KINDS,
    CampaignRecord,
    Described,
    RecordKind,
    described,
    kind_of,
)

__all__ = ["Described", "described", "reference_groups_in", "references_out"]


def reference_groups_in(
    desc: RobotDescription, measurements: Sequence[CampaignRecord], described: Described, *, sigma_mm: float
) -> tuple[tuple[ReferenceRecords, ...], list[str]]:
    """The records grouped by the reference they measure (internal units), each record keeping its place in
    the campaign (`sigma_mm`: a record's σ where it states none); and the notes the conversion makes. A record
    that names an undescribed anchor, a description no record uses: a 4xx naming it."""
    by_reference: dict[tuple[RecordKind, str], list[int]] = {}
    for i, record in enumerate(measurements):
        kind = kind_of(record)
        by_reference.setdefault((kind, kind.reference_name(record)), []).append(i)
    _check_descriptions(described, by_reference)
    notes: list[str] = []
    groups = []
    for (kind, name), index in by_reference.items():
        records = [measurements[i] for i in index]
        groups.append(kind.group(desc, described, name, records, index, sigma_mm=sigma_mm))
        notes += kind.notes(records)
    return tuple(groups), notes


def _check_descriptions(body: Described, used: dict[tuple[RecordKind, str], list[int]]) -> None:
    for (kind, name), index in used.items():
        kind.check_described(body, name, index[0])
    for kind in RECORD_KINDS.values():
        for name in kind.descriptions(body):
            if (kind, name) not in used:
                raise BadRequest(
                    f"{kind.label} {name!r} is described but no record measures it: remove it, or check the "
                    f"records' {kind.label} names ({sorted(n for k, n in used if k is kind) or 'none'})"
                )


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
        entry.update(BY_MODEL[ref.traits.kind].reported(ref, np.asarray(estimate.values, dtype=float)))
        out.append(entry)
    return out


def _boundary(kind: Kind, value: float) -> float:
    return value * kind.to_boundary  # the parameters' own factor: mm stay mm, rad become deg
