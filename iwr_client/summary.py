"""The CLI's human output: a few lines per answer, the numbers an engineer reads first (`--json` prints the
API's documents instead). Values the API answers as null (a failed fit has no accuracy) print as '–'."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any


def _mm(value: object, digits: int = 4) -> str:
    return f"{value:.{digits}f} mm" if isinstance(value, int | float) else "–"


def robots_table(robots: Sequence[Mapping[str, Any]]) -> str:
    if not robots:
        return "no robots"
    rows = [("id", "name", "model", "version")]
    rows += [(r["id"], r["name"], r["model"], str(r["parameter_version"])) for r in robots]
    widths = [max(len(row[k]) for row in rows) for k in range(3)]
    return "\n".join(f"{a:<{widths[0]}}  {b:<{widths[1]}}  {c:<{widths[2]}}  {d}" for a, b, c, d in rows)


def robot_summary(robot: Mapping[str, Any]) -> str:
    joints = ", ".join(robot.get("joint_names", []))
    return (
        f"robot {robot['id']} created: {robot['name']} ({robot['model']}, {robot['parameter_count']} parameters, "
        f"parameter version {robot['parameter_version']})\n  joints: {joints}"
    )


def design_summary(design: Mapping[str, Any], csv_path: str | None) -> str:
    metrics = design.get("metrics") or {}
    baseline = design.get("random_baseline") or {}
    lines = [
        f"pose design {design['id']}: {design['count']} poses of {design['candidates']} candidates "
        f"(criterion {design['criterion']}, {design['measurement']} records)",
        f"  predicted TCP error after calibration: {_mm(metrics.get('predicted_rms_tcp_mm'))} RMS "
        f"(random poses: {_mm(baseline.get('predicted_rms_tcp_mm'))})",
    ]
    if design.get("efficiency") is not None:
        lines.append(f"  efficiency against the bound: {design['efficiency']:.3f}")
    lines.append(f"  poses written to {csv_path}" if csv_path else "  (--csv FILE writes the poses for the pendant)")
    return "\n".join(lines)


def calibration_summary(calibration: Mapping[str, Any]) -> str:
    """Status, applied or why not, RMS before → after, predicted accuracy."""
    head = f"calibration {calibration['id']}: {calibration['status']}"
    if calibration["status"] == "failed":
        return f"{head}\n  reason: {calibration.get('reason') or 'not given'}"
    if calibration.get("applied"):
        head += f", applied as parameter version {calibration.get('parameter_version')}"
    else:
        head += ", not applied"
    residuals = calibration.get("residuals") or {}
    before, after = residuals.get("before") or {}, residuals.get("after") or {}
    accuracy = calibration.get("predicted_accuracy") or {}
    lines = [
        head,
        f"  residuals RMS: {_mm(before.get('rms_mm'), 3)} before → {_mm(after.get('rms_mm'))} after "
        f"(max {_mm(before.get('max_mm'), 3)} → {_mm(after.get('max_mm'))})",
        f"  predicted TCP accuracy: {_mm(accuracy.get('rms_position_mm'))} RMS, "
        f"{_mm(accuracy.get('max_position_mm'))} max",
    ]
    if isinstance(calibration.get("variance_factor"), int | float):
        lines.append(f"  variance factor {calibration['variance_factor']:.2f} (1: the stated noise fits)")
    if calibration.get("not_applied_reason"):
        lines.append(f"  not applied: {calibration['not_applied_reason']}")
    return "\n".join(lines)


def validation_summary(validation: Mapping[str, Any]) -> str:
    lines = [f"validation {validation['id']}: {validation['measurements']} {validation['measurement']} records"]
    for result in validation["results"]:
        position = result["position_mm"]
        registered = ", instrument frame registered" if result.get("registered") else ""
        lines.append(
            f"  version {result['version']}: position error {_mm(position['rms'])} RMS, "
            f"{_mm(position['max'])} max{registered}"
        )
    return "\n".join(lines)
