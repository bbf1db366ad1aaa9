"""Which candidate poses a cell can measure, and why each other one is refused.

`check_poses(desc, cell, joints)` evaluates every candidate at once: the stage frames in one batched call
(`models.cell.frames`), the instruments' cheap tests in numpy, and the collision and sight-line distances with
python-fcl, only for the pairs of solids whose bounding spheres come within the clearance (a numpy pre-pass:
most pairs of most poses never reach the library). Each refused candidate is counted once, under the first test
it fails, in the order of `Reason` (cheapest first).
"""

from __future__ import annotations

import itertools
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import fcl  # type: ignore[import-untyped]
import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.cell.cell import Cell, Obstacle, Pair, pair
from models.cell.frames import frame_layout, stage_frames
from models.cell.geometry import Attached, RobotGeometry, Segment, default_geometry
from models.cell.instruments import Ballbar, Camera, Target, Tracker
from models.cell.shapes import capsule_geometry, collision_geometry
from models.description.robot import RobotDescription
from models.description.serial_chain import JointType
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput
from models.kinematics import pose_batch, solve_platforms
from models.transforms import rotvec_to_matrix_np
from models.workspace import sample_workspace

JOINT_TOLERANCE = 1e-9
ALWAYS_POSES = 32


class Reason(StrEnum):
    """Why a candidate is refused, in the order the tests run."""

    JOINT_LIMITS = "joint_limits"
    OUT_OF_RANGE = "out_of_range"
    INCIDENCE = "incidence"
    FIELD_OF_VIEW = "field_of_view"
    BALLBAR_REACH = "ballbar_reach"
    SELF_COLLISION = "self_collision"
    CELL_COLLISION = "cell_collision"
    LINE_OF_SIGHT = "line_of_sight"


@dataclass(frozen=True)
class Feasibility:
    """Per candidate: whether the cell can measure it, and if not the first reason and what caused it."""

    feasible: NDArray[np.bool_]
    reasons: tuple[str, ...]
    """The `Reason` value, '' where feasible."""
    details: tuple[str, ...]
    """What failed: the pair of solids and their distance, the angle, the range (mm, degrees)."""

    @property
    def counts(self) -> dict[str, int]:
        """Refused candidates by reason (reasons with none left out)."""
        return dict(Counter(r for r in self.reasons if r))


# ------------------------------------------------------------------------------------------------ solids
SPHERES = 4
"""Bounding spheres per robot shape for the pre-pass: a segment's are strung along it, so that a pair of long
capsules reaches the library only where some of their spheres come near (one sphere a capsule sent ~50 pairs
a pose to it)."""


@dataclass(frozen=True)
class _Placed:
    """The robot's shapes placed for a batch: world transforms (N, S, 4, 4), capsule lengths for segments, and
    the pre-pass's bounding spheres (centres (N, S, SPHERES, 3), radii (S,))."""

    bodies: tuple[str, ...]
    transforms: Array
    lengths: Array
    centres: Array
    radii: Array
    outer: Array
    """Each shape's one bounding sphere's radius (its centre is the transform's origin): the coarse pass."""
    shapes: tuple[Segment | Attached, ...]
    _objects: dict[tuple[int, int], fcl.CollisionObject] = field(default_factory=dict)

    def geometry(self, n: int, s: int) -> object:
        shape = self.shapes[s]
        if isinstance(shape, Segment):
            return capsule_geometry(shape.radius, round(float(self.lengths[n, s]), 6))
        return collision_geometry(shape.shape)

    def object(self, n: int, s: int) -> fcl.CollisionObject:
        """Shape s placed for pose n (made once per check)."""
        found = self._objects.get((n, s))
        if found is None:
            t = self.transforms[n, s]
            found = self._objects[n, s] = fcl.CollisionObject(self.geometry(n, s), fcl.Transform(t[:3, :3], t[:3, 3]))
        return found


def _z_frames(a: Array, b: Array) -> Array:
    """(…, 4, 4) frames centred between a and b, z along b - a (any x for a zero-length segment)."""
    axis = b - a
    length = np.linalg.norm(axis, axis=-1, keepdims=True)
    z = np.where(length > 1e-12, axis / np.where(length > 1e-12, length, 1.0), np.array([0.0, 0.0, 1.0]))
    helper = np.where(np.abs(z[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    x = np.cross(helper, z)
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    out = np.zeros((*a.shape[:-1], 4, 4))
    out[..., :3, 0], out[..., :3, 1], out[..., :3, 2] = x, y, z
    out[..., :3, 3] = 0.5 * (a + b)
    out[..., 3, 3] = 1.0
    return out


def _place(geometry: RobotGeometry, names: tuple[str, ...], frames: Array) -> _Placed:
    index = {name: k for k, name in enumerate(names)}
    n, s = frames.shape[0], len(geometry.shapes)
    transforms = np.zeros((n, s, 4, 4))
    lengths = np.zeros((n, s))
    centres = np.zeros((n, s, SPHERES, 3))
    radii = np.zeros(s)
    along = (np.arange(SPHERES) + 0.5) / SPHERES
    for k, shape in enumerate(geometry.shapes):
        if isinstance(shape, Segment):
            fa, fb = frames[:, index[shape.frame_a]], frames[:, index[shape.frame_b]]
            pa = fa[:, :3, :3] @ np.asarray(shape.a) + fa[:, :3, 3]
            pb = fb[:, :3, :3] @ np.asarray(shape.b) + fb[:, :3, 3]
            transforms[:, k] = _z_frames(pa, pb)
            lengths[:, k] = np.linalg.norm(pb - pa, axis=1)
            centres[:, k] = pa[:, None, :] + along[None, :, None] * (pb - pa)[:, None, :]
            radii[k] = shape.radius + 0.5 * lengths[:, k].max(initial=0.0) / SPHERES
        else:
            transforms[:, k] = frames[:, index[shape.frame]] @ shape.matrix
            centres[:, k] = transforms[:, k, None, :3, 3]
            radii[k] = shape.shape.bounding_radius
    outer = np.array([sh.shape.bounding_radius if isinstance(sh, Attached) else sh.radius for sh in geometry.shapes])
    outer = outer + 0.5 * lengths.max(axis=0, initial=0.0)
    bodies = tuple(sh.body for sh in geometry.shapes)
    return _Placed(bodies, transforms, lengths, centres, radii, outer, geometry.shapes)


@dataclass(frozen=True)
class _Fixed:
    """The obstacles' collision objects, and for the pre-pass their boxes (world <- box rotations and centres,
    half extents) and bounding spheres."""

    names: tuple[str, ...]
    objects: tuple[fcl.CollisionObject, ...]
    rotations: Array
    centres: Array
    halves: Array
    radii: Array

    def box_distance(self, points: Array, j: int) -> Array:
        """Distance of points (..., 3) from obstacle j's box (0 inside): a lower bound of the distance to it."""
        local = np.abs((points - self.centres[j]) @ self.rotations[j]) - self.halves[j]
        return np.asarray(np.linalg.norm(np.maximum(local, 0.0), axis=-1), dtype=float)


def _fixed(obstacles: tuple[Obstacle, ...]) -> _Fixed:
    rotations = np.array([rotvec_to_matrix_np(np.asarray(o.pose[3:], dtype=float)) for o in obstacles]).reshape(
        -1, 3, 3
    )
    centres = np.array([o.pose[:3] for o in obstacles], dtype=float).reshape(-1, 3)
    objects = tuple(
        fcl.CollisionObject(collision_geometry(o.shape), fcl.Transform(r, t))
        for o, r, t in zip(obstacles, rotations, centres, strict=True)
    )
    return _Fixed(
        tuple(o.name for o in obstacles),
        objects,
        rotations,
        centres,
        np.array([o.shape.half_extents for o in obstacles], dtype=float).reshape(-1, 3),
        np.array([o.shape.bounding_radius for o in obstacles], dtype=float),
    )


def _distance(a: fcl.CollisionObject, b: fcl.CollisionObject) -> float:
    """Least distance between two solids (≤ 0 where they overlap)."""
    result = fcl.DistanceResult()
    d = float(fcl.distance(a, b, fcl.DistanceRequest(), result))
    if d <= 0:
        return min(d, 0.0)
    return d


def _gap(d: float) -> str:
    # The library reports overlapping solids as a negative number, not their depth
    return "overlapping" if d <= 0 else f"{d:.1f} mm apart"


# ------------------------------------------------------------------------------------------------ checks
class _Verdicts:
    """The first failing reason per candidate (candidates already refused are not tested again)."""

    def __init__(self, n: int) -> None:
        self.reasons = [""] * n
        self.details = [""] * n
        self.refused = np.zeros(n, dtype=bool)

    def open(self) -> NDArray[np.intp]:
        return np.flatnonzero(~self.refused)

    def refuse(self, k: int, reason: Reason, detail: str) -> None:
        if not self.refused[k]:
            self.reasons[k], self.details[k] = reason.value, detail
            self.refused[k] = True


def _target_points(frames: Array, target: Target) -> tuple[Array, Array]:
    tcp = frames[:, -1]
    point = tcp[:, :3, :3] @ np.asarray(target.offset) + tcp[:, :3, 3]
    facing = tcp[:, :3, :3] @ (np.asarray(target.facing) / np.linalg.norm(target.facing))
    return point, facing


def _angle(u: Array, v: Array) -> Array:
    cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.asarray(np.arccos(np.clip(cos, -1.0, 1.0)), dtype=float)


def _tracker(v: _Verdicts, rows: NDArray[np.intp], frames: Array, tracker: Tracker) -> None:
    point, facing = _target_points(frames, tracker.reflector)
    to_tracker = np.asarray(tracker.position) - point
    dist = np.linalg.norm(to_tracker, axis=1)
    angle = _angle(facing, to_tracker)
    far = (dist < tracker.range_min) | (dist > tracker.range_max)
    lo, hi = tracker.range_min, tracker.range_max
    for i in np.flatnonzero(far).tolist():
        v.refuse(
            int(rows[i]), Reason.OUT_OF_RANGE, f"reflector {dist[i]:.0f} mm from the tracker, range {lo:.0f}-{hi:.0f}"
        )
    cone = np.degrees(tracker.acceptance)
    for i in np.flatnonzero(~far & (angle > tracker.acceptance)).tolist():
        v.refuse(
            int(rows[i]),
            Reason.INCIDENCE,
            f"beam {np.degrees(angle[i]):.1f}° off the reflector's axis, cone {cone:.1f}°",
        )


def _camera(v: _Verdicts, rows: NDArray[np.intp], frames: Array, camera: Camera) -> None:
    point, facing = _target_points(frames, camera.target)
    r = rotvec_to_matrix_np(np.asarray(camera.pose[3:], dtype=float))
    c = np.asarray(camera.pose[:3], dtype=float)
    local = (point - c) @ r  # camera frame: R^T (p - c)
    depth = local[:, 2]
    safe = np.where(depth > 0, depth, 1.0)
    across, up = np.abs(np.arctan2(local[:, 0], safe)), np.abs(np.arctan2(local[:, 1], safe))
    angle = _angle(facing, c - point)
    for i, k in enumerate(rows):
        if not camera.range_min <= depth[i] <= camera.range_max:
            v.refuse(
                k,
                Reason.OUT_OF_RANGE,
                f"target {depth[i]:.0f} mm deep, camera's range {camera.range_min:.0f}-{camera.range_max:.0f}",
            )
        elif across[i] > camera.half_width or up[i] > camera.half_height:
            v.refuse(
                k, Reason.FIELD_OF_VIEW, f"target {np.degrees(across[i]):.1f}° across, {np.degrees(up[i]):.1f}° up"
            )
        elif angle[i] > camera.acceptance:
            v.refuse(k, Reason.INCIDENCE, f"target faces {np.degrees(angle[i]):.1f}° away from the camera")


def _ballbar(v: _Verdicts, rows: NDArray[np.intp], frames: Array, ballbar: Ballbar) -> None:
    point, _ = _target_points(frames, Target(offset=ballbar.tcp_offset))
    length = np.linalg.norm(point - np.asarray(ballbar.pivot), axis=1)
    for i, k in enumerate(rows):
        if not ballbar.length_min <= length[i] <= ballbar.length_max:
            v.refuse(
                k,
                Reason.BALLBAR_REACH,
                f"ballbar length {length[i]:.1f} mm, travel {ballbar.length_min:.1f}-{ballbar.length_max:.1f}",
            )


def _pairs(cell: Cell, fixed: _Fixed) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """Shape pairs to test: (robot, robot) of different non-allowed bodies; (robot, obstacle) not allowed."""
    shapes = cell.geometry.shapes
    own = [
        (i, j)
        for i in range(len(shapes))
        for j in range(i + 1, len(shapes))
        if shapes[i].body != shapes[j].body and pair(shapes[i].body, shapes[j].body) not in cell.allowed
    ]
    against = [
        (i, j)
        for i in range(len(shapes))
        for j in range(len(fixed.names))
        if pair(shapes[i].body, fixed.names[j]) not in cell.allowed
    ]
    return own, against


def _collisions(v: _Verdicts, rows: NDArray[np.intp], placed: _Placed, cell: Cell, fixed: _Fixed) -> None:
    own, against = _pairs(cell, fixed)
    clearance = cell.clearance
    c, r = placed.centres, placed.radii
    middle, outer = placed.transforms[:, :, :3, 3], placed.outer
    for i, j in own:
        # The pre-pass on the poses still open: one sphere a shape, then the strings of spheres
        at = np.flatnonzero(~v.refused[rows])
        far = (outer[i] + outer[j] + clearance) ** 2
        at = at[np.square(middle[at, i] - middle[at, j]).sum(axis=-1) < far]
        reach = (r[i] + r[j] + clearance) ** 2
        between = np.square(c[at, i, :, None, :] - c[at, j, None, :, :]).sum(axis=-1).min(axis=(1, 2))
        for n in at[between < reach].tolist():
            d = _distance(placed.object(n, i), placed.object(n, j))
            if d < clearance:
                v.refuse(
                    int(rows[n]),
                    Reason.SELF_COLLISION,
                    f"{placed.bodies[i]} × {placed.bodies[j]}: {_gap(d)}, clearance {clearance:.1f} mm",
                )
    for i, j in against:
        at = np.flatnonzero(~v.refused[rows])
        gap = fixed.box_distance(c[at, i], j).min(axis=1) - r[i]
        for n in at[gap < clearance].tolist():
            d = _distance(placed.object(n, i), fixed.objects[j])
            if d < clearance:
                v.refuse(
                    int(rows[n]),
                    Reason.CELL_COLLISION,
                    f"{placed.bodies[i]} × {fixed.names[j]}: {_gap(d)}, clearance {clearance:.1f} mm",
                )


def _sight(
    v: _Verdicts,
    rows: NDArray[np.intp],
    frames: Array,
    placed: _Placed,
    fixed: _Fixed,
    *,
    source: Array,
    target: Target,
    radius: float,
    what: str,
) -> None:
    """The sight line from `source` to the target: a capsule of `radius` that no solid may touch, but the bodies
    that carry the target."""
    if rows.size == 0:
        return
    point, _ = _target_points(frames, target)
    beams = _z_frames(np.broadcast_to(source, point.shape), point)
    lengths = np.linalg.norm(point - source, axis=1)
    robot = [s for s, body in enumerate(placed.bodies) if body not in target.carried_by]
    # Distance of each bounding centre from the beam's segment: solids farther than their radius + the
    # beam's never reach the library.
    axis = point - source
    span = np.maximum(np.einsum("ij,ij->i", axis, axis), 1e-12)

    def near(centres: Array, radii: Array) -> NDArray[np.bool_]:
        t = np.clip(np.einsum("nsj,nj->ns", centres - source, axis) / span[:, None], 0.0, 1.0)
        closest = source + t[..., None] * axis[:, None, :]
        return np.asarray(np.linalg.norm(centres - closest, axis=-1) < radii + radius, dtype=bool)

    m = placed.centres.shape[2]
    spheres = near(placed.centres[:, robot].reshape(len(rows), -1, 3), np.repeat(placed.radii[robot], m))
    close_robot = np.asarray(spheres.reshape(len(rows), len(robot), m).any(axis=2), dtype=bool)
    close_fixed = near(np.broadcast_to(fixed.centres, (len(rows), *fixed.centres.shape)), fixed.radii)
    todo = (close_robot.any(axis=1) | close_fixed.any(axis=1)) & ~v.refused[rows]
    for n in map(int, np.flatnonzero(todo)):
        k = int(rows[n])
        t = beams[n]
        beam = fcl.CollisionObject(
            capsule_geometry(radius, round(float(lengths[n]), 6)), fcl.Transform(t[:3, :3], t[:3, 3])
        )
        for s in np.flatnonzero(close_robot[n]):
            d = _distance(beam, placed.object(n, robot[s]))
            if d <= 0:
                v.refuse(k, Reason.LINE_OF_SIGHT, f"{what} crosses {placed.bodies[robot[s]]}")
                break
        else:
            for j in np.flatnonzero(close_fixed[n]):
                if _distance(beam, fixed.objects[j]) <= 0:
                    v.refuse(k, Reason.LINE_OF_SIGHT, f"{what} crosses {fixed.names[j]}")
                    break


def _instruments(v: _Verdicts, rows: NDArray[np.intp], ends: Array, cell: Cell) -> None:
    """Range, incidence, field of view and reach: from the TCP frames `ends` (N, 1, 4, 4) alone."""
    if cell.tracker is not None:
        _tracker(v, rows, ends, cell.tracker)
    if cell.camera is not None:
        _camera(v, rows, ends, cell.camera)
    if cell.ballbar is not None:
        _ballbar(v, rows, ends, cell.ballbar)


def _sight_lines(
    v: _Verdicts, rows: NDArray[np.intp], frames: Array, placed: _Placed, *, cell: Cell, fixed: _Fixed
) -> None:
    lines = []
    if cell.tracker is not None:
        tr = cell.tracker
        lines.append((tr.position, tr.reflector, tr.beam_clearance, "the tracker's beam"))
    if cell.camera is not None:
        cam = cell.camera
        lines.append((cam.pose[:3], cam.target, cam.sight_clearance, "the camera's sight line"))
    for source, target, radius, what in lines:
        _sight(
            v,
            rows,
            frames,
            placed,
            fixed,
            source=np.asarray(source, dtype=float),
            target=target,
            radius=radius,
            what=what,
        )


def check_poses(
    desc: RobotDescription,
    cell: Cell,
    joints: Array,
    params: Array | None = None,
    *,
    runtime: Runtime | None = None,
) -> Feasibility:
    """Which of `joints` (N, n_joints; internal units) the cell can measure (see the module docstring)."""
    q = np.atleast_2d(np.asarray(joints, dtype=float))
    if q.shape[1] != desc.n_joints:
        raise InvalidInput(f"joints need {desc.n_joints} columns, got {q.shape[1]}", field="joints")
    layout = frame_layout(desc)
    cell.geometry.check(layout)
    v = _Verdicts(q.shape[0])
    inside = np.all((q >= desc.joint_min - JOINT_TOLERANCE) & (q <= desc.joint_max + JOINT_TOLERANCE), axis=1)
    for k in np.flatnonzero(~inside):
        bad = int(np.flatnonzero((q[k] < desc.joint_min) | (q[k] > desc.joint_max))[0])
        v.refuse(int(k), Reason.JOINT_LIMITS, f"joint {desc.joint_names[bad]} outside its range")
    rows = v.open()
    if rows.size:
        # The instruments need the TCP alone (the compiled forward kinematics); they refuse most random poses
        # (a reflector's cone), so only the rest get every frame, are placed and tested for collisions.
        rt = runtime_for(desc, runtime)
        theta = desc.parameters.nominal if params is None else np.asarray(params, dtype=float)
        platforms, _ = solve_platforms(desc, q[rows], theta, runtime=rt)
        tcp = pose_batch(desc, q[rows], theta, platforms, runtime=rt)
        ends = np.zeros((rows.size, 1, 4, 4))
        ends[:, 0, :3, :3], ends[:, 0, :3, 3], ends[:, 0, 3, 3] = tcp.rotations, tcp.positions, 1.0
        _instruments(v, rows, ends, cell)
        keep = np.flatnonzero(~v.refused[rows])
        rows = rows[keep]
        frames = stage_frames(desc, q[rows], theta, platforms=platforms[keep], runtime=rt)
        placed = _place(cell.geometry, layout.names, frames)
        fixed = _fixed(cell.obstacles)
        _collisions(v, rows, placed, cell, fixed)
        _sight_lines(v, rows, frames, placed, cell=cell, fixed=fixed)
    return Feasibility(~v.refused, tuple(v.reasons), tuple(v.details))


# ------------------------------------------------------------------------------------------------ defaults
def default_allowed(
    desc: RobotDescription,
    geometry: RobotGeometry,
    obstacles: tuple[Obstacle, ...] = (),
    clearance: float = 10.0,
    poses: Array | None = None,
    *,
    runtime: Runtime | None = None,
) -> dict[Pair, str]:
    """The pairs a cell allows to touch by default, each with why: `adjacent` bodies along the chain, the bodies
    `across a prismatic joint`, and pairs
    `always touching`: within the clearance at every one of `poses` (default: the middle of the joint ranges and
    ALWAYS_POSES poses drawn in the workspace, seeded): a base on its table, a wrist's overlapping capsules. A
    pair that touches only sometimes is a collision the check must see, so it is never allowed by default."""
    layout = frame_layout(desc)
    geometry.check(layout)
    order = layout.body_order
    out: dict[Pair, str] = {}
    bodies = [b for b in order if b in geometry.bodies]
    for a, b in itertools.pairwise(bodies):
        out[pair(a, b)] = "adjacent"
    # A prismatic link's bodies on either side slide along each other (a telescope's sleeves, a carriage on
    # its rail): they touch by design wherever the stroke is short.
    chain = [b for b in order if b.startswith("link")]
    for k, link in enumerate(desc.links):
        if link.joint is JointType.PRISMATIC and 0 < k < len(chain) - 1:
            out.setdefault(pair(chain[k - 1], chain[k + 1]), "across a prismatic joint")
    if poses is None:
        middle = 0.5 * (desc.joint_min + desc.joint_max)
        poses = np.vstack([middle[None, :], sample_workspace(desc, ALWAYS_POSES, seed=0, runtime=runtime)])
    q = np.atleast_2d(np.asarray(poses, dtype=float))
    placed = _place(geometry, layout.names, stage_frames(desc, q, runtime=runtime))
    fixed = _fixed(obstacles)
    shapes = geometry.shapes
    n = q.shape[0]

    def always(i: int, other: Callable[[int], fcl.CollisionObject]) -> bool:
        return all(_distance(placed.object(k, i), other(k)) < clearance for k in range(n))

    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            p = pair(shapes[i].body, shapes[j].body)
            if len(p) == 2 and p not in out and always(i, lambda k, j=j: placed.object(k, j)):  # type: ignore[misc]
                out[p] = "always touching"
        for j, name in enumerate(fixed.names):
            p = pair(shapes[i].body, name)
            if p not in out and always(i, lambda _k, j=j: fixed.objects[j]):  # type: ignore[misc]
                out[p] = "always touching"
    return out


def cell_for(
    desc: RobotDescription,
    *,
    geometry: RobotGeometry | None = None,
    obstacles: tuple[Obstacle, ...] = (),
    tracker: Tracker | None = None,
    camera: Camera | None = None,
    ballbar: Ballbar | None = None,
    clearance: float = 10.0,
    poses: Array | None = None,
    runtime: Runtime | None = None,
) -> Cell:
    """A cell with the default allowed pairs (`default_allowed`) and, without a geometry, the links' defaults."""
    g = default_geometry(desc) if geometry is None else geometry
    allowed = default_allowed(desc, g, obstacles, clearance, poses, runtime=runtime)
    return Cell(g, obstacles, tracker, camera, ballbar, clearance, frozenset(allowed))
