"""Cheap checks before a fit that name the likely slip and the records it touches.

A campaign in the wrong units or conventions ends, without these, in a generic failure ("the hexapod poses do
not assemble", a fit 10⁴ σ off) that names no cause. Each check compares the data with the nominal (or
starting) model in closed form: no iteration, milliseconds for hundreds of poses.

- `RADIANS`: every revolute joint reads within ±π although its range is far wider: degrees were expected.
- `LENGTH_SCALE`: the best similarity fit of the model's TCP positions onto the measured ones has a scale near
  0.001 (metres), 1/25.4 (inches) or 1000 (µm) instead of 1.
- `REFLECTION`: a mirrored fit is much better than any rotation: a left-handed instrument frame (one axis
  flipped), which no rigid base can represent.
- `QUATERNION_ORDER`: the orientations fit far better read as `[x, y, z, w]` than as `[w, x, y, z]`.
- `TOOL_ORIENTATION` (not blocking): every record's orientation differs from the model's by one constant
  rotation on the tool's side (a reflector's or tool frame's orientation far from the description's): the fit
  starts from the measured one and estimates it.
- `ORIENTATION_FLIP`: orientation residuals near 180° after registration that no constant tool rotation
  explains (a sign or frame convention in the instrument's orientation output).
- `FAR_RECORDS`: single records far off the rest after a robust registration (this record, not the campaign).
- `TEMPERATURE_TERM`, `LOAD_TERM` (after a fit, `models.identification.terms_check`): the geometric fit
  fails its variance-factor test and its residuals follow the records' temperatures (payloads).
- `OTHER_PLANE` (after a fit against planes, `models.identification.reference_diagnosis`): the touches of a
  plane that fail it lie on a plane of their own, another face touched under the same name.
- `JOINT_CONVENTION`: the rigid fit is poor as sent, and near-perfect with one joint's readings negated or
  shifted by ±90° or 180°: the controller's sign or zero of that joint differs from the description's.
- `MISMATCH`: no placement of the robot, rigid or scaled or mirrored, comes near the measured positions: the
  joint rows and the measurements do not belong together (shuffled files, another robot's campaign).
Internal units throughout (mm, rad); the messages state boundary units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.parameters import Kind
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.errors import CalibrationError
from models.kinematics import forward_kinematics
from models.transforms import quaternion_to_matrix

MIN_RECORDS = 5
RADIANS_RANGE_DEG = 20.0
"""Only revolute joints whose range is wider than this can betray radians (a ±3° joint reads ±π either way)."""
RADIANS_TURNS = 4 * math.pi
"""Readings in radians lie within the joint's range in radians, up to two turns either way."""
SCALE_TOLERANCE = 0.2
"""A similarity scale within ±20 % of 1/1000, 1/25.4 or 1000 names that unit."""
REFLECTION_GAIN = 0.5
"""A mirrored fit whose RMS is below this fraction of the best rotation's marks a left-handed frame."""
FIT_QUALITY = 0.05
"""A unit or handedness slip leaves a near-perfect similarity fit (the robot's own error, a few mm in a metre of
spread); a fit worse than this fraction of the spread means the records do not match at all (another finding)."""
FLIP_DEG = 150.0
TOOL_OFFSET_DEG = 10.0
"""A constant tool-side rotation larger than this is taken from the records as the fit's start…"""
TOOL_SPREAD_DEG = 5.0
"""…when every record agrees on it within this (median): the tool frame, not the instrument, is off."""
FAR_MAD = 8.0
"""A record is far off when its residual exceeds the median by this many robust σ (1.4826 MAD)…"""
FAR_MIN_MM = 10.0
"""…and by at least this much: the nominal model itself is millimetres off before a calibration."""
MAX_LISTED = 10
MISMATCH_SHARE = 0.25
"""A best rigid fit whose RMS exceeds this fraction of the points' spread explains nothing (clean: ~0.01)."""


class Finding(StrEnum):
    RADIANS = "radians"
    LENGTH_SCALE = "length_scale"
    REFLECTION = "reflection"
    QUATERNION_ORDER = "quaternion_order"
    ORIENTATION_FLIP = "orientation_flip"
    TOOL_ORIENTATION = "tool_orientation"
    JOINT_CONVENTION = "joint_convention"
    """One joint's readings fit far better negated or shifted by ±90°/180°: a sign or zero convention."""
    """Not blocking: the records' orientations differ from the model's by one constant tool-side rotation."""
    FAR_RECORDS = "far_records"
    MISMATCH = "mismatch"
    TEMPERATURE_TERM = "temperature_term"
    """After a fit that fails its variance-factor test: the residuals follow the records' temperatures."""
    LOAD_TERM = "load_term"
    """After a fit that fails its variance-factor test: the residuals follow the records' payloads."""
    OTHER_PLANE = "other_plane"
    """After a fit against planes: some touches of a plane lie on another plane of their own (another face)."""


@dataclass(frozen=True)
class Diagnosis:
    finding: Finding
    message: str
    """What is wrong and what to do, in boundary units."""
    records: tuple[int, ...] = ()
    """The records concerned (0-based, campaign order); empty when it is the whole campaign."""
    blocking: bool = True
    """True when no fit can succeed until it is fixed; False for records a robust fit can leave out."""
    tool_rotation: Array | None = None
    """TOOL_ORIENTATION: the constant rotation C (3×3) with measured ≈ model · C, tool side."""


def _listed(records: list[int]) -> str:
    shown = ", ".join(str(r) for r in records[:MAX_LISTED])
    return shown + (f" and {len(records) - MAX_LISTED} more" if len(records) > MAX_LISTED else "")


def check_radians(desc: RobotDescription, joints: Array) -> Diagnosis | None:
    """Revolute readings (rad inside) that, as degrees, all lie within ±π although the range is wide."""
    wide = [
        j
        for j, kind in enumerate(desc.joint_kinds)
        if kind is Kind.ANGLE and math.degrees(desc.joint_max[j] - desc.joint_min[j]) > RADIANS_RANGE_DEG
    ]
    if not wide or joints.shape[0] < MIN_RECORDS:
        return None
    as_degrees = np.degrees(joints[:, wide])
    # Radians lie within ±π, or within the joint's own range read as radians where that is wider (a ±360° or
    # ±400° wrist reads up to ±6.28 or ±6.98; such a campaign was called a mismatch, issue 45), never beyond two
    # turns: a ±10-turn joint's degrees could lie within its ±62.8.
    bound = np.clip(np.maximum(np.abs(desc.joint_min[wide]), np.abs(desc.joint_max[wide])), math.pi, RADIANS_TURNS)
    if np.all(np.abs(as_degrees) <= bound + 1e-9):
        names = ", ".join(desc.joint_names[j] for j in wide)
        return Diagnosis(
            Finding.RADIANS,
            f"every reading of the revolute joint(s) {names} lies within ±{float(bound.max()):.3g} although their "
            "ranges span tens of degrees: the joints look like radians; send them in degrees (in a file: a "
            "header 'q1 [rad]', or joint_unit=rad)",
        )
    return None


@dataclass(frozen=True)
class _Similarity:
    scale: float
    rotation: Array
    translation: Array
    rms_mm: float
    reflected: bool


def _similarity(source: Array, target: Array, *, allow_reflection: bool, with_scale: bool) -> _Similarity:
    """Umeyama's closed form: target ≈ s R source + t."""
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    u, sv, vt = np.linalg.svd(b.T @ a)
    d = np.ones(3)
    if not allow_reflection and np.linalg.det(u @ vt) < 0:
        d[2] = -1.0
    rotation = u @ np.diag(d) @ vt
    variance = float(np.sum(a**2))
    scale = float(np.sum(sv * d) / variance) if with_scale and variance > 0 else 1.0
    translation = mu_t - scale * rotation @ mu_s
    fitted = scale * a @ rotation.T + mu_t
    rms = float(np.sqrt(np.mean(np.sum((fitted - target) ** 2, axis=1))))
    return _Similarity(scale, rotation, translation, rms, bool(np.linalg.det(rotation) < 0))


def _spread(points: Array) -> float:
    """RMS distance of the points from their centroid (mm)."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


UNIT_SCALES = (("metres", 1e-3), ("inches", 1 / 25.4), ("micrometres", 1e3), ("centimetres", 0.1))


def check_length_scale(model: Array, measured: Array) -> Diagnosis | None:
    fit = _similarity(model, measured, allow_reflection=True, with_scale=True)
    if fit.rms_mm > FIT_QUALITY * _spread(measured):
        return None  # no similarity explains the data (shuffled records, another robot): not a unit slip
    for unit, scale in UNIT_SCALES:
        if abs(fit.scale / scale - 1) < SCALE_TOLERANCE:
            return Diagnosis(
                Finding.LENGTH_SCALE,
                f"the measured positions are {fit.scale:.4g}× the robot's size: they look like {unit}; "
                "send positions in millimetres (or choose the file's length unit)",
            )
    return None


def check_reflection(model: Array, measured: Array) -> Diagnosis | None:
    proper = _similarity(model, measured, allow_reflection=False, with_scale=False)
    mirrored = _similarity(model, measured, allow_reflection=True, with_scale=False)
    good = mirrored.rms_mm <= FIT_QUALITY * _spread(measured)
    if mirrored.reflected and good and mirrored.rms_mm < REFLECTION_GAIN * proper.rms_mm:
        return Diagnosis(
            Finding.REFLECTION,
            f"the measured positions fit the robot mirrored ({mirrored.rms_mm:.3g} mm RMS) far better than by any "
            f"rotation ({proper.rms_mm:.3g} mm): the instrument frame looks left-handed (one axis flipped); "
            "check the instrument's axis convention",
        )
    return None


def _angles(a: Array, b: Array) -> Array:
    """Rotation angles between two stacks of rotation matrices."""
    cos = (np.einsum("nij,nij->n", a, b) - 1.0) / 2.0
    return np.asarray(np.arccos(np.clip(cos, -1.0, 1.0)), dtype=float)


def check_orientations(
    rotation_fit: Array, model_rotations: Array, quaternions: Array, index: NDArray[np.intp]
) -> Diagnosis | None:
    predicted = np.einsum("ij,njk->nik", rotation_fit, model_rotations)
    # First: a wrong component order or a flipped instrument axis scatters C_i = P_iᵀ M_i; a turned tool does not.
    tool = _constant_tool_rotation(predicted, quaternion_to_matrix(quaternions))
    if tool is not None:
        angle = math.degrees(float(np.arccos(np.clip((np.trace(tool) - 1.0) / 2.0, -1.0, 1.0))))
        return Diagnosis(
            Finding.TOOL_ORIENTATION,
            f"every record's orientation differs from the robot's by the same {angle:.3g}° rotation on the tool's "
            "side: the tool (reflector) frame's orientation in the description is off; the fit starts from the "
            "measured orientation and estimates it (correct the tool's orientation in the description to keep it)",
            blocking=False,
            tool_rotation=tool,
        )
    as_given = _angles(quaternion_to_matrix(quaternions), predicted)
    reordered = _angles(quaternion_to_matrix(np.roll(quaternions, 1, axis=1)), predicted)
    # Register the remaining constant offset away (the tool's orientation may be far from nominal): compare the
    # spread of each reading's error around its median, which a wrong component order cannot keep small.
    if np.median(reordered) < 0.2 * np.median(as_given) and np.median(as_given) > math.radians(5):
        return Diagnosis(
            Finding.QUATERNION_ORDER,
            f"the orientations fit {math.degrees(np.median(reordered)):.3g}° (median) read as [x, y, z, w] against "
            f"{math.degrees(np.median(as_given)):.3g}° as sent: send quaternions as [w, x, y, z] (scalar first)",
        )
    flipped = [int(index[k]) for k in np.flatnonzero(as_given > math.radians(FLIP_DEG))]
    if flipped:
        return Diagnosis(
            Finding.ORIENTATION_FLIP,
            f"records {_listed(flipped)} have orientations about 180° from the robot's: a flipped axis or frame "
            "convention in the instrument's orientation output",
            tuple(flipped),
        )
    return None


def _constant_tool_rotation(predicted: Array, measured: Array) -> Array | None:
    """The rotation C with measured_i ≈ predicted_i · C for every record, when there is one far from identity.

    A tool frame turned in the description (a reflector's nest 90° or 180° about an axis) is such a constant
    right factor; a flipped instrument axis or wrong records are not (their C_i scatter)."""
    offsets = np.einsum("nji,njk->nik", predicted, measured)  # C_i = P_iᵀ M_i
    u, _, vt = np.linalg.svd(offsets.sum(axis=0))
    mean = u @ np.diag([1.0, 1.0, float(np.linalg.det(u @ vt))]) @ vt  # the chordal mean rotation
    spread = _angles(offsets, np.broadcast_to(mean, offsets.shape))
    angle = float(np.arccos(np.clip((np.trace(mean) - 1.0) / 2.0, -1.0, 1.0)))
    if angle > math.radians(TOOL_OFFSET_DEG) and float(np.median(spread)) < math.radians(TOOL_SPREAD_DEG):
        return np.asarray(mean, dtype=float)
    return None


def check_far_records(model: Array, measured: Array, index: NDArray[np.intp]) -> Diagnosis | None:
    """Records far off after a robust registration: refit without the worst until the rest agree."""
    keep = np.ones(model.shape[0], dtype=bool)
    residual = np.zeros(model.shape[0])
    for _ in range(max(1, model.shape[0] // 10)):
        fit = _similarity(model[keep], measured[keep], allow_reflection=False, with_scale=False)
        residual = np.linalg.norm(fit.scale * model @ fit.rotation.T + fit.translation - measured, axis=1)
        median = float(np.median(residual[keep]))
        spread = 1.4826 * float(np.median(np.abs(residual[keep] - median)))
        far = residual > median + max(FAR_MAD * spread, FAR_MIN_MM)
        if not (far & keep).any():
            break
        keep &= ~far
        if keep.sum() < MIN_RECORDS:
            return None  # nothing agrees: a campaign-wide problem, which the other checks name
    records = [int(k) for k in np.flatnonzero(~keep)]
    if not records:
        return None
    worst = sorted(records, key=lambda k: -residual[k])
    details = ", ".join(f"{index[k]} ({residual[k]:.3g} mm)" for k in worst[:MAX_LISTED])
    return Diagnosis(
        Finding.FAR_RECORDS,
        f"{len(records)} record(s) lie far off all the others after registration: {details}"
        + (" …" if len(records) > MAX_LISTED else "")
        + "; check these records (joint row, point name) — the rest of the campaign agrees",
        tuple(int(index[k]) for k in worst),
        blocking=False,
    )


CONVENTION_SHIFTS_DEG = (180.0, 90.0, -90.0)
CONVENTION_GAIN = 0.2
"""A convention is named when it brings the rigid fit's median residual below this fraction of the fit as sent
(and to a fit as good as a unit slip's, `FIT_QUALITY`)."""


def check_joint_convention(
    desc: RobotDescription,
    joints: Array,
    measured: Array,
    params: Array,
    *,
    typical: float,
    runtime: Runtime | None,
) -> Diagnosis | None:
    """The one joint whose readings, negated or shifted by ±90°/180°, make the rigid fit near-perfect."""
    best: tuple[float, str] | None = None
    for j, kind in enumerate(desc.joint_kinds):
        if kind is not Kind.ANGLE:
            continue
        variants = [("negated", -joints[:, j])] + [
            (f"shifted by {shift:+.0f}°", joints[:, j] + math.radians(shift)) for shift in CONVENTION_SHIFTS_DEG
        ]
        for label, column in variants:
            trial = joints.copy()
            trial[:, j] = column
            try:
                fk = forward_kinematics(desc, trial, params, check_ranges=False, runtime=runtime)
            except CalibrationError:
                continue
            fit = _similarity(fk.positions, measured, allow_reflection=False, with_scale=False)
            residual = np.linalg.norm(fk.positions @ fit.rotation.T + fit.translation - measured, axis=1)
            median = float(np.median(residual))
            if best is None or median < best[0]:
                best = (median, f"joint {desc.joint_names[j]} {label}")
    if best is None or best[0] > CONVENTION_GAIN * typical or best[0] > FIT_QUALITY * _spread(measured):
        return None
    return Diagnosis(
        Finding.JOINT_CONVENTION,
        f"the measured positions fit the robot with {best[1]} ({best[0]:.3g} mm median) far better than as sent "
        f"({typical:.4g} mm): the controller's sign or zero of that joint differs from the description's; "
        "convert the readings (or the description's joint offset and direction) before calibrating",
    )


def _model_poses(
    desc: RobotDescription, joints: Array, params: Array, runtime: Runtime | None
) -> tuple[Array, Array, NDArray[np.intp]]:
    """Nominal TCP positions and rotations of the records the model can evaluate, and which those are."""
    try:
        fk = forward_kinematics(desc, joints, params, check_ranges=False, runtime=runtime)
        return fk.positions, fk.rotations, np.arange(joints.shape[0])
    except CalibrationError:
        pass
    good, positions, rotations = [], [], []
    for k in range(joints.shape[0]):
        try:
            fk = forward_kinematics(desc, joints[k : k + 1], params, check_ranges=False, runtime=runtime)
        except CalibrationError:
            continue
        good.append(k)
        positions.append(fk.positions[0])
        rotations.append(fk.rotations[0])
    if not good:
        return np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0, dtype=int)
    return np.array(positions), np.array(rotations), np.array(good)


def diagnose(
    desc: RobotDescription,
    joints: Array,
    positions: Array,
    quaternions: Array | None,
    params: Array,
    *,
    runtime: Runtime | None = None,
) -> tuple[Diagnosis, ...]:
    """Every finding for a campaign (internal units), most fundamental first; empty when nothing looks wrong."""
    found: list[Diagnosis] = []
    radians = check_radians(desc, joints)
    if radians is not None:
        return (radians,)  # with the joints wrong, any geometric comparison is meaningless
    model, model_rotations, usable = _model_poses(desc, joints, params, runtime)
    if usable.size < MIN_RECORDS:
        return ()
    measured = positions[usable]
    for check in (check_length_scale, check_reflection):
        finding = check(model, measured)
        if finding is not None:
            return (finding,)
    rigid = _similarity(model, measured, allow_reflection=False, with_scale=False)
    # The median residual, not the RMS: a few far records must not hide what the rest says.
    residual = np.linalg.norm(model @ rigid.rotation.T + rigid.translation - measured, axis=1)
    typical = float(np.median(residual))
    if typical > FIT_QUALITY * _spread(measured):
        convention = check_joint_convention(desc, joints[usable], measured, params, typical=typical, runtime=runtime)
        if convention is not None:
            return (convention,)
    if typical > MISMATCH_SHARE * _spread(measured):
        return (
            Diagnosis(
                Finding.MISMATCH,
                f"no placement of the robot comes near the measured positions (best fit {typical:.4g} mm median "
                f"over a spread of {_spread(measured):.4g} mm): these measurements cannot come from this robot at "
                "these joints — are the joint rows and the measurements of the same poses, in the same order?",
            ),
        )
    if typical > FIT_QUALITY * _spread(measured):
        return tuple(found)  # too poor a fit for the orientation and single-record checks to mean anything
    if quaternions is not None:
        fit = _similarity(model, measured, allow_reflection=False, with_scale=False)
        finding = check_orientations(fit.rotation, model_rotations, quaternions[usable], usable)
        if finding is not None:
            found.append(finding)
    far = check_far_records(model, measured, usable)
    if far is not None:
        found.append(far)
    return tuple(found)
