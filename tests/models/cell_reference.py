"""An independent check of a cell's verdicts: hand-written geometry, no collision library, no pre-pass.

Frames of a serial DH arm by the textbook product (numpy); capsule-capsule distance by the closed form of the
closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9); capsule-box and beam-box by
the exact point-box distance at points strung densely along the segment (their error is below half the
spacing, and verdicts that close to the threshold are called ambiguous and left out of comparisons).
"""

from __future__ import annotations

import numpy as np

from models.cell import Box, Cell, Reason, Segment, frame_layout
from models.description.robot import RobotDescription
from models.transforms import rotvec_to_matrix_np

SAMPLES = 800
MARGIN = 1.5
"""mm: a distance this close to its threshold makes the verdict ambiguous."""


def dh_frames(desc: RobotDescription, q: np.ndarray) -> np.ndarray:
    """(N, F, 4, 4) in `frame_layout(desc)` order for a serial standard-DH arm, written from the textbook."""
    n = q.shape[0]
    out = []

    def pose(p6: tuple[float, ...]) -> np.ndarray:
        t = np.tile(np.eye(4), (n, 1, 1))
        t[:, :3, :3] = rotvec_to_matrix_np(np.asarray(p6[3:]))
        t[:, :3, 3] = p6[:3]
        return t

    t = pose(desc.base)
    out.append(t)
    for k, link in enumerate(desc.links):
        th = link.theta + q[:, k]
        c, s = np.cos(th), np.sin(th)
        ca, sa = np.cos(link.alpha), np.sin(link.alpha)
        mid = np.tile(np.eye(4), (n, 1, 1))
        mid[:, 0, 0], mid[:, 0, 1], mid[:, 1, 0], mid[:, 1, 1] = c, -s, s, c
        mid[:, 2, 3] = link.d
        rest = np.eye(4)
        rest[:3, :3] = [[1, 0, 0], [0, ca, -sa], [0, sa, ca]]
        rest[0, 3] = link.a
        out.append(t @ mid)
        t = t @ mid @ rest
        out.append(t)
    out.append(t @ pose(desc.tool))
    return np.stack(out, axis=1)


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Least distance between segments p1q1 and p2q2, (N, 3) each: the closed form of their closest points."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = (d1 * d1).sum(-1), (d2 * d2).sum(-1), (d2 * r).sum(-1)
    c, b = (d1 * r).sum(-1), (d1 * d2).sum(-1)
    tiny = 1e-12
    denom = a * e - b * b
    s = np.where(denom > tiny, np.clip((b * f - c * e) / np.where(denom > tiny, denom, 1.0), 0, 1), 0.0)
    s = np.where(a <= tiny, 0.0, s)
    t = np.where(e > tiny, (b * s + f) / np.where(e > tiny, e, 1.0), 0.0)
    # t outside [0, 1]: clamp it and recompute s for the clamped t
    t_low, t_high = t < 0, t > 1
    t = np.clip(t, 0, 1)
    s = np.where(t_low, np.clip(-c / np.where(a > tiny, a, 1.0), 0, 1), s)
    s = np.where(t_high, np.clip((b - c) / np.where(a > tiny, a, 1.0), 0, 1), s)
    s = np.where(a <= tiny, 0.0, s)
    c1 = p1 + s[..., None] * d1
    c2 = p2 + t[..., None] * d2
    return np.asarray(np.linalg.norm(c1 - c2, axis=-1), dtype=float)


def segment_box_distance(
    p: np.ndarray, q: np.ndarray, centre: np.ndarray, rot: np.ndarray, half: np.ndarray
) -> np.ndarray:
    """Distance from segments pq (N, 3) to a box (centre, world <- box rotation, half sizes): exact point-box
    distances at SAMPLES points along each segment."""
    s = np.linspace(0.0, 1.0, SAMPLES)
    pts = p[:, None, :] + s[None, :, None] * (q - p)[:, None, :]
    local = np.abs((pts - centre) @ rot) - half
    return np.asarray(np.linalg.norm(np.maximum(local, 0.0), axis=-1).min(axis=1), dtype=float)


def slab_hit(p: np.ndarray, q: np.ndarray, centre: np.ndarray, rot: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Whether segments pq cross a box: the slab test (Kay-Kajiya) in the box's frame."""
    a, b = (p - centre) @ rot, (q - centre) @ rot
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-half - a) / d, (half - a) / d
    lo = np.where(np.abs(d) > 1e-12, np.minimum(t1, t2), np.where(np.abs(a) <= half, -np.inf, np.inf))
    hi = np.where(np.abs(d) > 1e-12, np.maximum(t1, t2), np.where(np.abs(a) <= half, np.inf, -np.inf))
    enter, leave = np.max(lo, axis=1), np.min(hi, axis=1)
    return np.asarray((enter <= leave) & (leave >= 0) & (enter <= 1), dtype=bool)


Ends = list[tuple[np.ndarray, np.ndarray]]
Boxes = list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]


def _ends(desc: RobotDescription, cell: Cell, frames: np.ndarray) -> Ends:
    names = frame_layout(desc).names
    ends = []
    for s in cell.geometry.shapes:
        assert isinstance(s, Segment)
        fa, fb = frames[:, names.index(s.frame_a)], frames[:, names.index(s.frame_b)]
        ends.append((fa[:, :3, :3] @ np.asarray(s.a) + fa[:, :3, 3], fb[:, :3, :3] @ np.asarray(s.b) + fb[:, :3, 3]))
    return ends


def _boxes(cell: Cell) -> Boxes:
    out = []
    for o in cell.obstacles:
        assert isinstance(o.shape, Box)
        rot = rotvec_to_matrix_np(np.asarray(o.pose[3:]))
        out.append((o.name, np.asarray(o.pose[:3], float), rot, 0.5 * np.array([o.shape.x, o.shape.y, o.shape.z])))
    return out


def _collisions(cell: Cell, ends: Ends, boxes: Boxes, fails: dict[Reason, np.ndarray], close: np.ndarray) -> None:
    shapes, clearance = cell.geometry.shapes, cell.clearance
    for i, a in enumerate(shapes):
        assert isinstance(a, Segment)
        for j in range(i + 1, len(shapes)):
            b = shapes[j]
            assert isinstance(b, Segment)
            if a.body == b.body or frozenset((a.body, b.body)) in cell.allowed:
                continue
            d = segment_distance(*ends[i], *ends[j]) - a.radius - b.radius
            fails[Reason.SELF_COLLISION] |= d < clearance
            close |= np.abs(d - clearance) < MARGIN
        for name, centre, rot, half in boxes:
            if frozenset((a.body, name)) in cell.allowed:
                continue
            d = segment_box_distance(*ends[i], centre, rot, half) - a.radius
            fails[Reason.CELL_COLLISION] |= d < clearance
            close |= np.abs(d - clearance) < MARGIN


def _tracker(
    cell: Cell, frames: np.ndarray, ends: Ends, boxes: Boxes, fails: dict[Reason, np.ndarray], close: np.ndarray
) -> None:
    tr = cell.tracker
    assert tr is not None
    tcp = frames[:, -1]
    point = tcp[:, :3, :3] @ np.asarray(tr.reflector.offset) + tcp[:, :3, 3]
    facing = tcp[:, :3, :3] @ (np.asarray(tr.reflector.facing) / np.linalg.norm(tr.reflector.facing))
    to = np.asarray(tr.position) - point
    dist = np.linalg.norm(to, axis=1)
    cos = (facing * to).sum(1) / dist
    fails[Reason.OUT_OF_RANGE] = (dist < tr.range_min) | (dist > tr.range_max)
    fails[Reason.INCIDENCE] = cos < np.cos(tr.acceptance)
    close |= np.abs(cos - np.cos(tr.acceptance)) < 1e-9
    source = np.broadcast_to(np.asarray(tr.position, float), point.shape)
    for i, s in enumerate(cell.geometry.shapes):
        assert isinstance(s, Segment)
        if s.body in tr.reflector.carried_by:
            continue
        d = segment_distance(source, point, *ends[i]) - s.radius - tr.beam_clearance
        fails[Reason.LINE_OF_SIGHT] |= d < 0
        close |= np.abs(d) < MARGIN
    for _, centre, rot, half in boxes:
        d = segment_box_distance(source, point, centre, rot, half) - tr.beam_clearance
        hit = slab_hit(source, point, centre, rot, half)
        assert not np.any(hit & (d > 0)), "the slab test and the sampled distance disagree"
        fails[Reason.LINE_OF_SIGHT] |= d < 0
        close |= np.abs(d) < MARGIN


def reference_verdicts(
    desc: RobotDescription, cell: Cell, q: np.ndarray, frames: np.ndarray
) -> tuple[list[str], np.ndarray]:
    """Per candidate the first failing reason ('' if none) in `Reason`'s order, and whether some test of it was
    within MARGIN of its threshold (ambiguous). Obstacles must be boxes, link shapes segments, the instrument a
    tracker or none."""
    n = q.shape[0]
    fails = {r: np.zeros(n, bool) for r in Reason}
    close = np.zeros(n, bool)
    fails[Reason.JOINT_LIMITS] = ~np.all((q >= desc.joint_min) & (q <= desc.joint_max), axis=1)
    ends, boxes = _ends(desc, cell, frames), _boxes(cell)
    _collisions(cell, ends, boxes, fails, close)
    if cell.tracker is not None:
        _tracker(cell, frames, ends, boxes, fails, close)
    out = [""] * n
    for k in range(n):
        out[k] = next((r.value for r in Reason if fails[r][k]), "")
    return out, close
