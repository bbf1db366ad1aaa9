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
    return "\n".join(lines + _read_as(validation))


def _read_as(answer: Mapping[str, Any]) -> list[str]:
    """What the service's file reader noted (columns mapped, units converted): how the file was understood."""
    return [f"  file: {note}" for note in answer.get("import_notes") or []]


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
    lines += _read_as(check)
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


# -- program compensation -----------------------------------------------------------------------------------------

PROGRAM_KEYS = frozenset({"format", "version", "program", "files", "targets", "base", "pendant", "warnings"})
"""The answer's members this summary lays out; any other the service adds is printed generically after them."""
TARGET_KEYS = frozenset(
    {
        "file",
        "line",
        "column",
        "name",
        "base_frame",
        "tool_frame",
        "reached",
        "correction_mm",
        "correction_deg",
        "reason",
    }
)


def _norm(vector: object) -> float | None:
    if not isinstance(vector, list | tuple) or not all(isinstance(v, int | float) for v in vector):
        return None
    return float(sum(v * v for v in vector) ** 0.5)


def _said(value: object) -> str:
    """Anything the service says (a message, a warning object, a list of them) as one line of text."""
    if isinstance(value, Mapping):
        for key in ("message", "reason", "detail"):
            if isinstance(value.get(key), str):
                return str(value[key])
        return ", ".join(f"{k} {_said(v)}" for k, v in value.items())
    if isinstance(value, list | tuple):
        return "; ".join(_said(v) for v in value)
    return "–" if value is None else str(value)


def _where(item: Mapping[str, Any], program: str) -> str:
    place = f"{item.get('file') or program}:{item['line']}" if item.get("line") is not None else ""
    return " ".join(p for p in (place, str(item.get("name") or "")) if p)


def target_notes(target: Mapping[str, Any]) -> str:
    """Why a target was kept, and whatever else the service says of it (warnings, a configuration)."""
    notes = [str(target["reason"])] if target.get("reason") else []
    notes += [
        f"{k.replace('_', ' ')}: {_said(v)}"
        for k, v in target.items()
        if k not in TARGET_KEYS and v not in (None, [], {})
    ]
    return "; ".join(notes)


def program_summary(answer: Mapping[str, Any], program: str, written: Sequence[str] = ()) -> str:
    """What was corrected, by how much and in which frames; what was kept and why; whatever else the answer holds
    (the service may add members: printed generically); the files written."""
    targets: list[Mapping[str, Any]] = list(answer.get("targets") or [])
    corrected = [t for t in targets if t.get("reached")]
    sizes = [_norm(t.get("correction_mm")) or 0.0 for t in corrected]
    turns = [_norm(t.get("correction_deg")) or 0.0 for t in corrected]
    head = (
        f"{program} compensated for version {answer.get('version')}: {len(corrected)} of {len(targets)} targets "
        f"corrected, {len(targets) - len(corrected)} kept"
    )
    if corrected:
        head += f" (largest correction {max(sizes):.3f} mm, {max(turns):.4f} deg)"
    lines = [head]
    if answer.get("base"):
        lines.append(f"  frames: {answer['base']}")
    header = ("file", "line", "name", "base", "tool", "status", "dx mm", "dy mm", "dz mm", "|d| mm", "|r| deg", "notes")
    rows: list[tuple[str, ...]] = [header]
    for t in targets:
        shift = t.get("correction_mm") if isinstance(t.get("correction_mm"), list) else None
        size, turn = _norm(shift), _norm(t.get("correction_deg"))
        rows.append(
            (
                str(t.get("file") or program),
                str(t.get("line", "–")),
                str(t.get("name") or "–"),
                str(t.get("base_frame") or "robot base"),
                str(t.get("tool_frame") or "model tool"),
                "corrected" if t.get("reached") else "kept",
                *([f"{v:+.3f}" for v in shift] if shift and len(shift) == 3 else ["–"] * 3),
                "–" if size is None else f"{size:.3f}",
                "–" if turn is None else f"{turn:.4f}",
                target_notes(t),
            )
        )
    if targets:
        lines.append(_table(rows))
    pendant = answer.get("pendant")
    if isinstance(pendant, Mapping):
        lines.append(f"  pendant check: {_said(pendant)}")
    lines += [f"  warning: {_said(w)}" for w in answer.get("warnings") or []]
    for key, value in answer.items():
        if key in PROGRAM_KEYS or value in (None, [], {}):
            continue
        title = key.replace("_", " ")
        if isinstance(value, list):
            lines.append(f"{title} ({len(value)}):")
            for item in value:
                where = _where(item, program) if isinstance(item, Mapping) else ""
                lines.append(f"  {where + ': ' if where else ''}{_said(item)}")
        else:
            lines.append(f"  {title}: {_said(value)}")
    if written:
        lines.append(f"  written: {', '.join(written)}")
    else:
        lines.append("  (-o DIR writes the compensated files)")
    return "\n".join(lines)


def _predicted(predicted: Mapping[str, Any] | None) -> str:
    if not predicted:
        return "not identified yet"
    return f"predicted RMS {_mm(predicted['rms_tcp_mm'])} mm, worst {_mm(predicted['max_tcp_mm'])} mm"


def _next_poses(poses: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = []
    for pose in poses:
        again = f" (again, for blunder record {pose['replaces']})" if pose.get("replaces") is not None else ""
        lines.append("  measure " + ", ".join(f"{v:.4f}" for v in pose["joints"]) + again)
    return lines


def adaptive_summary(campaign: Mapping[str, Any]) -> str:
    lines = [
        f"adaptive campaign {campaign['id']}: {campaign['status']}, {campaign['records']} records of "
        f"{campaign['budget']}, target {campaign['target']} {campaign['target_mm']} mm",
        f"  {_predicted(campaign.get('predicted'))}",
    ]
    if campaign.get("excluded"):
        lines.append(f"  blunders excluded: records {', '.join(str(i) for i in campaign['excluded'])}")
    if campaign.get("reason"):
        lines.append(f"  {campaign['reason']}")
    if campaign.get("calibration_id"):
        lines.append(f"  calibration {campaign['calibration_id']}")
    return "\n".join(lines + _next_poses(campaign.get("next") or []))


def adaptive_step_summary(step: Mapping[str, Any]) -> str:
    lines = [f"step {step['number']}: {step['records']} records, {_predicted(step.get('predicted'))}"]
    lines += [
        f"  blunder: record {b['record']} off by {b['position_mm']:.3f} mm (statistic {b['statistic']:.1f} > "
        f"{b['threshold']:.1f}), excluded"
        for b in step.get("blunders") or []
    ]
    lines.append(f"  done: {step['reason']}" if step["done"] else f"  next ({len(step['next'])} poses):")
    return "\n".join(lines + _next_poses(step.get("next") or []))
