"""A calibration's predicted accuracy at given poses, each judged against the region its campaign measured.

A calibration's covariance predicts the TCP's error anywhere, but the prediction is only as good as the model's
linearisation around what was measured: a campaign on a line leaves directions of the parameters unseen, and at a
pose that moves along them the first-order figure is both huge (64 mm, where the truth may be 0.05 mm) and
untested. And a pose far from every measured one may be predicted small (the covariance's correlations say so)
without any record having checked it. So each pose gets its figure *and* a verdict: inside the measured region,
or extrapolation with the reason — which joints left the measured spans, how far the nearest measured pose is,
and, where the figure is far above the region's, the direction of the parameters that makes it so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.parameters import Kind
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.identification.statistics import tcp_accuracy
from models.kinematics import CLOSURE_TOLERANCE_MM, pose_jacobian_batch, solve_platforms

SPAN_MARGIN = 0.05
"""A joint may pass the span its campaign measured by this share of its range and stay in the measured region
(a grid of poses measures the space between its rows, and a little around them)."""
NEAR_SHARE = 0.01
"""A pose this close to a measured pose (1 % of each joint's range) is in the region whatever the gaps inside it."""
GAP_FACTOR = 2.0
"""A pose further from its nearest measured pose than this times the widest gap inside the measured set (each
measured pose to its nearest neighbour) is away from the region, even inside every joint's span: a campaign on a
line spans the joints of a box it does not measure."""
FIGURE_RATIO = 3.0
"""A pose predicted more than this times the measured region's worst pose is extrapolation whatever its joints
(the same ratio as the workspace figure's: `models.identification.accuracy.EXTRAPOLATION_RATIO`)."""
SHOWN_COMPONENTS = 3


@dataclass(frozen=True)
class MeasuredRegion:
    """What a calibration's campaign measured, as the per-pose verdicts need it (internal units)."""

    joints: Array
    """(N, J) the campaign's joint vectors."""
    ranges: Array
    """(J,) each joint's full range (0: a joint without one, never judged)."""
    widest_gap: float
    """The largest distance (in shares of the ranges, the largest over joints) from a measured pose to its
    nearest measured neighbour."""
    rms_position_mm: float
    max_position_mm: float
    """The predicted 1-σ TCP position error at the measured poses: the figures a pose inside is comparable to."""


@dataclass(frozen=True)
class PoseAccuracy:
    position_mm: Array
    """(M,) predicted 1-σ TCP position error (√trace of its 3×3 covariance); NaN where the platform does not close."""
    orientation_rad: Array
    distance: Array
    """(M,) distance to the nearest measured pose, as the largest share of a joint's range."""
    extrapolation: tuple[str | None, ...]
    """Per pose: None inside the measured region, otherwise why the pose is extrapolation."""


def measured_region(
    desc: RobotDescription, measured: Array, theta: Array, free: NDArray[np.intp], cov_theta: Array, *, runtime: Runtime
) -> MeasuredRegion:
    """The region of a campaign's joint vectors `measured`, with the covariance's prediction on it."""
    ranges = np.asarray(desc.joint_max - desc.joint_min, dtype=float)
    ranges = np.where(np.isfinite(ranges) & (ranges > 0), ranges, 0.0)
    gaps = _nearest(measured, measured, ranges, exclude_self=True)
    pos, _, _ = _sigma(desc, measured, theta, free, cov_theta, runtime=runtime)
    finite = pos[np.isfinite(pos)]
    return MeasuredRegion(
        joints=measured,
        ranges=ranges,
        widest_gap=float(gaps.max()) if gaps.size else 0.0,
        rms_position_mm=float(np.sqrt(np.mean(finite**2))) if finite.size else float("nan"),
        max_position_mm=float(finite.max()) if finite.size else float("nan"),
    )


def pose_accuracy(
    desc: RobotDescription,
    joints: Array,
    theta: Array,
    free: NDArray[np.intp],
    cov_theta: Array,
    *,
    region: MeasuredRegion,
    runtime: Runtime,
) -> PoseAccuracy:
    """The predicted 1-σ TCP error at each of `joints` from the covariance `cov_theta` of the parameters `free`
    (first order), and whether each pose lies in `region`. `cov_theta` is the calibration's
    `prediction_covariance` where it has one: its full a-posteriori covariance overstates a line campaign's own
    line 6× (the unseen directions' noise, and their variances inverted at condition 1e17)."""
    scales = desc.parameters.scales[free]
    pos, rot, jac = _sigma(desc, joints, theta, free, cov_theta, runtime=runtime)
    distance = _nearest(joints, region.joints, region.ranges, exclude_self=False)
    # The covariance's directions in tolerances (mm and rad compare), once for every pose that names one.
    values, vectors = np.linalg.eigh(cov_theta / np.outer(scales, scales))
    judge = _Judge(
        desc, region, np.clip(values, 0.0, None), vectors, tuple(desc.parameters.names[i] for i in free), scales
    )
    reasons = tuple(judge.reason(joints[m], float(pos[m]), float(distance[m]), jac[m]) for m in range(joints.shape[0]))
    return PoseAccuracy(position_mm=pos, orientation_rad=rot, distance=distance, extrapolation=reasons)


def _sigma(
    desc: RobotDescription, joints: Array, theta: Array, free: NDArray[np.intp], cov_theta: Array, *, runtime: Runtime
) -> tuple[Array, Array, Array]:
    """Per-pose 1-σ position and orientation, and the (M, 3, n) position Jacobians on `free` (NaN where the
    platform does not close)."""
    platforms, closure = solve_platforms(desc, joints, theta, runtime=runtime)
    ok: NDArray[np.bool_] = np.asarray(closure <= CLOSURE_TOLERANCE_MM, dtype=bool)
    pos = np.full(joints.shape[0], np.nan)
    rot = np.full(joints.shape[0], np.nan)
    jac = np.full((joints.shape[0], 3, free.size), np.nan)
    if ok.any():
        fk = pose_jacobian_batch(desc, joints[ok], theta, platforms[ok], runtime=runtime)
        on_free = fk.jacobians[:, :, free]
        pos[ok], rot[ok] = tcp_accuracy(on_free, cov_theta)
        jac[ok] = on_free[:, :3, :]
    return pos, rot, jac


def _nearest(poses: Array, measured: Array, ranges: Array, *, exclude_self: bool) -> Array:
    """Each pose's distance to its nearest measured pose: the largest over joints of |Δq| / range."""
    judged = ranges > 0
    if not measured.shape[0] or not judged.any():
        return np.zeros(poses.shape[0])
    scaled_poses = poses[:, judged] / ranges[judged]
    scaled_measured = measured[:, judged] / ranges[judged]
    out = np.empty(poses.shape[0])
    for start in range(0, poses.shape[0], 512):  # bounded memory: 512 × N × J at a time
        chunk = np.abs(scaled_poses[start : start + 512, None, :] - scaled_measured[None, :, :]).max(axis=2)
        if exclude_self:
            rows = np.arange(chunk.shape[0])
            chunk[rows, start + rows] = np.inf
        out[start : start + 512] = chunk.min(axis=1) if chunk.shape[1] else 0.0
    return np.where(np.isfinite(out), out, 0.0)


@dataclass(frozen=True)
class _Judge:
    """What a pose is judged against: the region, and the covariance's directions (in tolerances: variances and
    eigenvectors as columns) to name one by."""

    desc: RobotDescription
    region: MeasuredRegion
    variances: Array
    directions: Array
    names: tuple[str, ...]
    scales: Array

    def direction(self, jacobian: Array) -> str:
        """The direction of the parameters that carries most of this pose's predicted variance, by its largest
        components."""
        moved = (jacobian * self.scales) @ self.directions  # (3, n): how each direction moves the TCP per tolerance
        v = self.directions[:, int(np.argmax(self.variances * np.sum(moved**2, axis=0)))]
        order = np.argsort(-np.abs(v))
        v = v * np.sign(v[order[0]])
        return " ".join(f"{v[i]:+.2f}·{self.names[i]}" for i in order[:SHOWN_COMPONENTS] if abs(v[i]) >= 0.1)

    def reason(self, q: Array, position_mm: float, distance: float, jacobian: Array) -> str | None:
        """None for a pose inside the region, else the sentence that says why it is extrapolation."""
        region = self.region
        if not np.isfinite(position_mm):
            return "the platform does not close at these joints: no prediction"
        parts = _outside_spans(self.desc, q, region)
        if distance > max(GAP_FACTOR * region.widest_gap, NEAR_SHARE):
            parts.append(
                f"its nearest measured pose is {100 * distance:.0f} % of a joint's range away (measured poses lie "
                f"within {100 * region.widest_gap:.0f} % of one another)"
            )
        if np.isfinite(region.max_position_mm) and position_mm > FIGURE_RATIO * region.max_position_mm:
            direction = self.direction(jacobian)
            parts.append(
                f"its predicted {position_mm:.3g} mm is {position_mm / region.max_position_mm:.0f}× the measured "
                f"region's worst ({region.max_position_mm:.3g} mm), mostly along {direction}"
            )
        if not parts:
            return None
        # Measured (a line campaign, poses in the joint box around it): 6.8 mm predicted there, 139 mm missed — the
        # instrument frame's turn about the line is unseen, and its start is the registration's, not a tolerance.
        return f"extrapolation: {'; '.join(parts)}. No record saw this pose: its figure is no bound on the error"


def _outside_spans(desc: RobotDescription, q: Array, region: MeasuredRegion) -> list[str]:
    out = []
    lo, hi = region.joints.min(axis=0), region.joints.max(axis=0)
    for j, name in enumerate(desc.joint_names):
        margin = SPAN_MARGIN * region.ranges[j]
        if region.ranges[j] > 0 and not lo[j] - margin <= q[j] <= hi[j] + margin:
            angle = desc.joint_kinds[j] is Kind.ANGLE
            shown = np.degrees if angle else (lambda v: v)
            unit = "°" if angle else " mm"
            out.append(
                f"{name} at {shown(q[j]):.4g}{unit} outside the measured {shown(lo[j]):.4g}…{shown(hi[j]):.4g}{unit}"
            )
    return out
