"""Parameter versions as responses, the diff of two versions, and an imported parameter list as values."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models import RobotDescription
from models.errors import InvalidInput
from service.persistence.tables import ParameterVersion
from service.schemas.versions import ParameterVersionImport, ParameterVersionPublic, VersionDiffPublic


def version_out(row: ParameterVersion, current: int) -> ParameterVersionPublic:
    return ParameterVersionPublic.model_validate(
        {
            "version": row.version,
            "provenance": row.provenance,
            "calibration_id": row.calibration_id,
            "restored_from": row.restored_from,
            "created_at": row.created_at,
            "actor": row.actor,
            "current": row.version == current,
            "conditions": row.conditions,
        }
    )


def _std(row: ParameterVersion, n: int) -> list[float | None]:
    raw = [*(row.std_errors or [])[:n], *([None] * max(0, n - len(row.std_errors or [])))]
    return [None if v is None or not math.isfinite(float(v)) else float(v) for v in raw]


def _values(row: ParameterVersion, nominal: np.ndarray) -> np.ndarray:
    out = nominal.copy()
    stored = np.asarray(row.values, dtype=float)[: nominal.size]
    out[: stored.size] = stored
    return out


def diff_out(desc: RobotDescription, robot_id: str, a: ParameterVersion, b: ParameterVersion) -> VersionDiffPublic:
    table = desc.parameters
    scale = table.to_boundary
    # A version without the model terms `desc` has (calibrated without them) holds their nominal values.
    raw_a, raw_b = _values(a, table.nominal), _values(b, table.nominal)
    va, vb = raw_a * scale, raw_b * scale
    sa, sb = _std(a, len(table)), _std(b, len(table))
    rows: list[dict[str, Any]] = []
    sigmas: list[float] = []
    geometry: list[float] = []
    # The base is where the instrument stood (registration), not the robot: a tracker moved between two
    # campaigns changes it by thousands of σ while the geometry is unchanged (max_abs_sigma 126 720 was the
    # base's). The diff says which rows it is and ranks the geometry apart.
    registration = set(range(len(table))[desc.slices["base"]])
    for i, name in enumerate(table.names):
        std_a = None if sa[i] is None else sa[i] * scale[i]
        std_b = None if sb[i] is None else sb[i] * scale[i]
        known = [s for s in (std_a, std_b) if s is not None]
        # A value no calibration estimated (nominal, unidentifiable) has no estimation error: it counts as exact.
        combined = math.sqrt(sum(s * s for s in known)) if known else None
        difference = float(vb[i] - va[i])
        sigma = difference / combined if combined else None
        if sigma is not None:
            sigmas.append(abs(sigma))
            if i not in registration:
                geometry.append(abs(sigma))
        rows.append(
            {
                "name": name,
                "unit": table.units[i],
                "a": float(va[i]),
                "b": float(vb[i]),
                "difference": difference,
                "std_error_a": std_a,
                "std_error_b": std_b,
                "std_error": combined,
                "difference_sigma": sigma,
                "registration": i in registration,
            }
        )
    changed = [name for i, name in enumerate(table.names) if raw_a[i] != raw_b[i]]
    return VersionDiffPublic.model_validate(
        {
            "robot_id": robot_id,
            "a": a.version,
            "b": b.version,
            "parameters": rows,
            "changed": changed,
            "max_abs_sigma": max(sigmas) if sigmas else None,
            "geometry_max_abs_sigma": max(geometry) if geometry else None,
        }
    )


def import_in(desc: RobotDescription, body: ParameterVersionImport) -> tuple[list[float], list[Any], list[Any]]:
    """Values (internal units), std errors and identifiable flags of every parameter, each named once."""
    table = desc.parameters
    index = {name: i for i, name in enumerate(table.names)}
    seen: dict[str, int] = {}
    for k, p in enumerate(body.parameters):
        if p.name not in index:
            raise InvalidInput(
                f"parameters[{k}].name: {p.name!r} is not a parameter of this robot", field=f"parameters[{k}].name"
            )
        if p.name in seen:
            raise InvalidInput(
                f"parameters[{k}].name: {p.name!r} is given twice (also at {seen[p.name]})",
                field=f"parameters[{k}].name",
            )
        if p.unit is not None and p.unit != table.units[index[p.name]]:
            raise InvalidInput(
                f"parameters[{k}].unit: {p.name} is in {table.units[index[p.name]]}, not {p.unit}",
                field=f"parameters[{k}].unit",
            )
        seen[p.name] = k
    missing = [n for n in table.names if n not in seen]
    if missing:
        raise InvalidInput(
            f"parameters: {len(missing)} missing, e.g. {', '.join(missing[:3])}; send all of them", field="parameters"
        )
    scale = table.to_boundary
    values = [0.0] * len(table)
    std: list[float | None] = [None] * len(table)
    ident: list[bool | None] = [None] * len(table)
    for p in body.parameters:
        i = index[p.name]
        values[i] = float(p.value / scale[i])
        std[i] = None if p.std_error is None else float(p.std_error / scale[i])
        ident[i] = p.identifiable
    return values, list(std), list(ident)
