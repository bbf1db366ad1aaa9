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
    return _table(rows)


def _table(rows: Sequence[Sequence[str]]) -> str:
    """Rows of cells in columns two spaces apart, each as wide as its widest cell (the header is the first row)."""
    widths = [max(len(row[k]) for row in rows) for k in range(len(rows[0]))]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows)


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


def check_summary(check: Mapping[str, Any]) -> str:
    """The verdict with its statistic, what explains a change, and the recommendation."""
    statistic = check["statistic"]
    lines = [
        f"check {check['id']}: {check['verdict']} (version {check['version']}, {check['measurements']} records; "
        f"chi2 {statistic['chi2']:.1f} against {statistic['threshold']:.1f} at alpha {statistic['alpha']:g}, "
        f"p = {statistic['p_value']:.3g})"
    ]
    explanation = check.get("explanation")
    if explanation:
        changes = ", ".join(
            f"{c['name']} {c['change']:+.4f} ± {c['std_error']:.4f} {c['unit']}" for c in explanation["parameters"]
        )
        lines.append(f"  explained by {explanation['name']}: {changes}")
    lines.append(f"  to do: {check['recommendation']['message']}")
    lines += [f"  warning: {w.get('message') or w}" for w in check.get("warnings") or []]
    return "\n".join(lines)


def check_design_summary(plan: Mapping[str, Any], csv_path: str | None) -> str:
    seen = [w for w in plan["watched"] if w.get("detectable") is not None]
    lines = [f"{len(plan['poses'])} check poses ({plan['measurement']} records) for version {plan['version']}"]
    lines += [f"  sees {w['name']} change by {w['detectable']:.4g} {w['unit']} (95 %)" for w in seen[:8]]
    lines.append(f"  poses written to {csv_path}" if csv_path else "  (--csv FILE writes the poses for the pendant)")
    return "\n".join(lines)


def history_table(events: Sequence[Mapping[str, Any]]) -> str:
    if not events:
        return "no calibrations or checks yet"
    rows = [("at", "kind", "outcome", "version", "measured", "expected")]
    rows += [
        (
            str(e["at"])[:19].replace("T", " "),
            e["kind"],
            e["outcome"],
            "–" if e.get("version") is None else str(e["version"]),
            _mm(e.get("rms_mm")),
            _mm(e.get("predicted_mm")),
        )
        for e in events
    ]
    return _table(rows)
