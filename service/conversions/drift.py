"""Drift-aware campaigns at the boundary: the records' times and reference marks as a `Timeline`, the fitted
drift as the report's `drift`, a campaign's conditions (the ranges a version is calibrated for) and the
warnings of a request that runs the robot outside them."""

from __future__ import annotations

import math
from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any, cast

import numpy as np

from models import RobotDescription
from models.campaign import Campaign
from models.identification.drift import DriftDriver, DriftEstimate, Timeline, find_reference
from service.errors import BadRequest
from service.record_kinds import kind_of
from service.record_kinds.tracker import Record
from service.schemas.common import ConditionsPublic, ConditionWarningPublic, Payload

HOUR_S = 3600.0


def _instant(text: str) -> datetime:
    moment = datetime.fromisoformat(text)  # the schema checked it parses
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def record_times(records: Sequence[Record]) -> tuple[np.ndarray | None, list[datetime] | None]:
    """The records' times in seconds from the first record's (None: no record has one), and their instants when
    they are ISO times; 400 naming the record when only some records have one, or numbers and times mix."""
    given = [r.time for r in records]
    missing = [i for i, t in enumerate(given) if t is None]
    if len(missing) == len(given):
        return None, None
    if missing:
        raise BadRequest(
            f"record {missing[0]}: it has no time while other records have one; give every record a time or none "
            f"({len(missing)} of {len(given)} have none)",
            record=missing[0],
        )
    texts = [isinstance(t, str) for t in given]
    if any(texts) and not all(texts):
        first = texts.index(not texts[0])
        raise BadRequest(
            f"record {first}: times mix seconds and ISO 8601 times; give every record the same kind of time",
            record=first,
        )
    if all(texts):
        instants = [_instant(str(t)) for t in given]
        return np.array([(m - instants[0]).total_seconds() for m in instants]), instants
    seconds = np.array(given, dtype=float)
    return seconds - seconds[0], None


def timeline_in(desc: RobotDescription, records: Sequence[Record], campaign: Campaign) -> Timeline:
    """When each record was measured (its order without times) and the reference pose's records: those marked
    `reference`, or the pose measured most often where none is marked (422 when none is repeated)."""
    times, _ = record_times(records)
    marked = np.flatnonzero([r.reference for r in records]).astype(np.intp)
    reference = marked if marked.size else find_reference(desc, campaign.joints)
    if times is None:
        return Timeline(np.arange(len(records), dtype=np.float64), reference, timed=False)
    return Timeline(times, reference, timed=True)


def drift_out(estimate: DriftEstimate) -> dict[str, Any]:
    """The report's `drift` (mm; rates per hour or kelvin)."""
    total = estimate.total_mm
    sigma = [float(s) if math.isfinite(s) else None for s in estimate.total_sigma_mm]
    timed = estimate.driver is DriftDriver.TIME and estimate.timed
    over = "temperature_c" if estimate.driver is DriftDriver.TEMPERATURE else ("seconds" if timed else "records")
    extent = estimate.extent
    rate_h = (total / (extent / HOUR_S)).tolist() if timed else None
    rate_k = (total / extent).tolist() if estimate.driver is DriftDriver.TEMPERATURE else None
    return {
        "driver": estimate.driver.value,
        "degree": estimate.degree,
        "over": over,
        "span": [float(estimate.span[0]), float(estimate.span[1])],
        "over_campaign_mm": total.tolist(),
        "over_campaign_sigma_mm": sigma,
        "magnitude_mm": float(np.linalg.norm(total)),
        "rate_mm_per_h": rate_h,
        "rate_mm_per_k": rate_k,
        "coefficients_mm": estimate.coefficients_mm.tolist(),
        "reference_records": [int(i) for i in estimate.reference],
        "reference_scatter": {
            "before_mm": estimate.reference_scatter_before_mm,
            "after_mm": estimate.reference_scatter_after_mm,
        },
        "rounds": estimate.rounds,
    }


def _range(values: Sequence[float]) -> dict[str, float] | None:
    return {"min": float(min(values)), "max": float(max(values))} if values else None


def conditions_out(records: Sequence[object], payload: Payload | None) -> dict[str, Any]:
    """What a campaign's records were measured under (any kind of record: those without a temperature, a
    payload or a time count for none)."""
    temperatures = [t for r in records if (t := getattr(r, "temperature_c", None)) is not None]
    loads = [p for r in records if (p := getattr(r, "payload", None) or payload) is not None]
    timed = all(kind_of(r).timed for r in records)
    times, instants = record_times(cast(Sequence[Record], records)) if timed else (None, None)
    return ConditionsPublic.model_validate(
        {
            "temperature_c": _range(temperatures),
            "payload_kg": _range([p.mass_kg for p in loads]),
            "time": None if not instants else [min(instants).isoformat(), max(instants).isoformat()],
            "duration_s": None if times is None else float(np.max(times) - np.min(times)),
            "records": len(records),
        }
    ).model_dump(mode="json")


def condition_warnings(
    calibrated: dict[str, Any] | None,
    *,
    version: int,
    temperatures: Sequence[float],
    payloads_kg: Sequence[float],
) -> list[ConditionWarningPublic]:
    """One warning per condition of a request outside the range `calibrated` (a version's stored conditions;
    None: a version no campaign made, nothing to compare) with the farthest value and by how much."""
    if not calibrated:
        return []
    warnings = []
    for name, values, unit in (("temperature_c", temperatures, "°C"), ("payload_kg", payloads_kg, "kg")):
        bounds = calibrated.get(name)
        if not bounds or not values:
            continue
        low, high = float(bounds["min"]), float(bounds["max"])
        below, above = low - min(values), max(values) - high
        if max(below, above) <= 0:
            continue
        value, by = (min(values), below) if below >= above else (max(values), above)
        what = "temperature" if name == "temperature_c" else "payload"
        warnings.append(
            ConditionWarningPublic.model_validate(
                {
                    "condition": name,
                    "value": value,
                    "calibrated": {"min": low, "max": high},
                    "outside_by": by,
                    "version": version,
                    "message": f"{what} {value:g} {unit} is {by:g} {unit} outside the {low:g}–{high:g} {unit} "
                    f"version {version} was calibrated under: its accuracy there is not what was measured",
                }
            )
        )
    return warnings
