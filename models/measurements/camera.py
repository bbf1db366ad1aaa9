"""A calibrated camera as a reference (`kind: "image"`): the pixels where it sees known points, with its own pose
(6 unknowns) identified with the robot's parameters.

The camera's intrinsics are known (a prior calibration, OpenCV's pinhole model with Brown–Conrady distortion):
a point X in the camera's frame (z forward, X₃ > 0) projects to
    x' = X₁/X₃, y' = X₂/X₃, r² = x'² + y'², ρ = 1 + k₁r² + k₂r⁴ + k₃r⁶,
    x'' = x'ρ + 2p₁x'y' + p₂(r² + 2x'²),  y'' = y'ρ + p₁(r² + 2y'²) + 2p₂x'y',
    u = fx x'' + cx,  v = fy y'' + cy.
Two mounts, one algebra: with y a point in the camera's parent frame and (R_c, t) the camera's pose in that
frame, X = R_cᵀ (y − t).
- `Camera` (mounted in the cell, "world"): it sees markers given in the TOOL frame, y = R m + p (R, p the TCP
  pose); its pose is in the world frame.
- `ToolCamera` (on the tool, "tool", hand-eye): it sees points given in the WORLD frame (a board in the cell),
  y = Rᵀ (b − p) is the point in the tool frame; its pose is in the tool (TCP) frame.
The pose's unknowns are its position (mm) and a rotation vector ω (rad) turning its start orientation,
R_c = exp([ω]×) R₀: six numbers, no constraint (as a plane's two angles), and ω stays small because the start
is the closed-form estimate of `started`.

Records: one per seen point, not one per image. Every other reference's record has a fixed number of rows, and
the fit's χ² machinery counts on it (the outlier test's degrees of freedom per record, the covariance's
m − n); an image with a variable number of points would need padded rows that falsify both. Per point, the
outlier test also catches the common blunder — one mis-detected or mis-matched marker — and drops that point,
keeping the image's good ones; an image taken at wrong joints fails all its points and they go one by one. The
points of an image share its joints, which is how pose design puts them back together into one candidate
(`optimal_design.references`). A record's values are (image, point, target x, y, z (mm), u, v (px)): the first
two only name it in messages.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from models._types import Array
from models.description.parameters import Kind, ParameterSpec
from models.errors import InvalidInput
from models.kinematics import ForwardJacobianResult, ForwardResult
from models.measurements.references import (
    ANGLE_SCALE_RAD,
    SLIP_RATIO,
    ReferenceBase,
    ReferenceRecords,
    Traits,
    position_specs,
)
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

MIN_FOCAL_PX = 100.0
"""Below this a focal length is not in pixels: a lens's focal length in mm (4–50) was given instead."""
MAX_ASPECT = 2.0
"""fx/fy beyond this (or below its inverse) is no camera's pixel aspect: one of them is in another unit."""
SLIP_MISFIT_PX = 20.0
"""A start misfit the nominal model's errors cannot explain (a millimetre at a metre and a half is ~1 px) ..."""
CANNOT_FIT_PX = 50.0
"""... and one no camera with these intrinsics can have (the median point's): the projection does not fit."""
UNDISTORT_ITERATIONS = 20


def skew(v: Array) -> Array:
    """[v]× of vectors (..., 3): skew(v) @ w = v × w."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2], out[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    out[..., 1, 0], out[..., 2, 0], out[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return out


def left_jacobian(w: Array) -> Array:
    """J_l(ω) of SO(3): exp([ω + dω]×) = exp([J_l dω]×) exp([ω]×) to first order."""
    angle = float(np.linalg.norm(w))
    k = skew(w)
    if angle < 1e-8:
        return np.asarray(np.eye(3) + 0.5 * k + k @ k / 6.0)
    return np.asarray(np.eye(3) + (1 - np.cos(angle)) / angle**2 * k + (angle - np.sin(angle)) / angle**3 * (k @ k))


@dataclass(frozen=True)
class Intrinsics:
    """A camera's calibration: focal lengths and principal point in pixels, OpenCV's (k₁, k₂, p₁, p₂, k₃), and
    the image's size (None: twice the principal point)."""

    fx: float
    fy: float
    cx: float
    cy: float
    distortion: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    width: float | None = None
    height: float | None = None

    def check(self, camera: str) -> None:
        """Numbers a camera in pixels has; an InvalidInput naming the field and the slip otherwise."""
        numbers = (self.fx, self.fy, self.cx, self.cy, *self.distortion)
        if len(self.distortion) != 5 or not np.all(np.isfinite(numbers)):
            raise InvalidInput(
                f"camera {camera!r}: fx, fy, cx, cy and the five distortion coefficients [k1, k2, p1, p2, k3] must "
                "be finite numbers",
                field=f"cameras.{camera}",
                reason="intrinsics",
            )
        for name, f in (("fx", self.fx), ("fy", self.fy)):
            if f < MIN_FOCAL_PX:
                raise InvalidInput(
                    f"camera {camera!r}: {name} = {f:g} is not a focal length in pixels (it looks like the lens's "
                    f"focal length in mm); give it in pixels: the focal length divided by the pixel pitch",
                    field=f"cameras.{camera}.{name}",
                    reason="focal_unit",
                    min=MIN_FOCAL_PX,
                )
        if not 1 / MAX_ASPECT <= self.fx / self.fy <= MAX_ASPECT:
            raise InvalidInput(
                f"camera {camera!r}: fx / fy = {self.fx / self.fy:.3g}: no camera's pixels are that far from square; "
                "give both in pixels",
                field=f"cameras.{camera}",
                reason="focal_unit",
            )
        if self.cx <= 0 or self.cy <= 0:
            raise InvalidInput(
                f"camera {camera!r}: the principal point (cx, cy) is in pixels from the image's top-left corner, "
                "both positive",
                field=f"cameras.{camera}",
                reason="principal_point",
            )

    def project(self, x_cam: Array) -> tuple[Array, Array]:
        """Pixels (n, 2) of camera-frame points (n, 3) and ∂(u, v)/∂X (n, 2, 3); NaN for points with X₃ ≤ 0 (a
        camera sees nothing behind it: the fit steps back from there)."""
        z = np.where(x_cam[:, 2] > 0, x_cam[:, 2], np.nan)
        x, y = x_cam[:, 0] / z, x_cam[:, 1] / z
        distorted, d_dist = self.distort(x, y)
        focal = np.array([self.fx, self.fy])
        pixels = distorted * focal + np.array([self.cx, self.cy])
        d_norm = np.zeros((x.size, 2, 3))
        d_norm[:, 0, 0], d_norm[:, 1, 1] = 1 / z, 1 / z
        d_norm[:, 0, 2], d_norm[:, 1, 2] = -x / z, -y / z
        return pixels, focal[None, :, None] * (d_dist @ d_norm)

    def distort(self, x: Array, y: Array) -> tuple[Array, Array]:
        """(x'', y'') (n, 2) of normalised (x', y') and their Jacobian (n, 2, 2)."""
        k1, k2, p1, p2, k3 = self.distortion
        r2 = x**2 + y**2
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        d_radial = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # ∂ρ/∂r²
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x**2)
        yd = y * radial + p1 * (r2 + 2 * y**2) + 2 * p2 * x * y
        jac = np.empty((x.size, 2, 2))
        jac[:, 0, 0] = radial + 2 * x**2 * d_radial + 2 * p1 * y + 6 * p2 * x
        jac[:, 0, 1] = 2 * x * y * d_radial + 2 * p1 * x + 2 * p2 * y
        jac[:, 1, 0] = jac[:, 0, 1]
        jac[:, 1, 1] = radial + 2 * y**2 * d_radial + 6 * p1 * y + 2 * p2 * x
        return np.column_stack([xd, yd]), jac

    def normalised(self, pixels: Array) -> Array:
        """The undistorted normalised coordinates (x', y') (n, 2) of pixels (n, 2): the distortion inverted by
        fixed-point iteration, as OpenCV's undistortPoints (a lens's distortion is a small correction)."""
        target = (pixels - np.array([self.cx, self.cy])) / np.array([self.fx, self.fy])
        k1, k2, p1, p2, k3 = self.distortion
        xy = target.copy()
        for _ in range(UNDISTORT_ITERATIONS):
            x, y = xy[:, 0], xy[:, 1]
            r2 = x**2 + y**2
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            tangential = np.column_stack([2 * p1 * x * y + p2 * (r2 + 2 * x**2), p1 * (r2 + 2 * y**2) + 2 * p2 * x * y])
            xy = (target - tangential) / radial[:, None]
        return np.asarray(xy)

    def inside(self, pixels: Array) -> Array:
        """Which pixels fall on the image (0..width, 0..height)."""
        width = 2 * self.cx if self.width is None else self.width
        height = 2 * self.cy if self.height is None else self.height
        u, v = pixels[:, 0], pixels[:, 1]
        return np.asarray(np.isfinite(u) & np.isfinite(v) & (u >= 0) & (u <= width) & (v >= 0) & (v <= height))


@dataclass(frozen=True)
class Camera(ReferenceBase):
    """A camera in the cell (world-mounted) seeing markers on the tool; `position` and `rotation` (a rotation
    vector: camera frame → world) its start pose, mm and rad (`started` estimates it from the records)."""

    name: str
    intrinsics: Intrinsics
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[float, float, float] = (0.0, 0.0, 0.0)

    mount: ClassVar[str] = "world"
    seen_frame: ClassVar[str] = "tool"
    """The frame its records' target points are given in."""
    traits: ClassVar[Traits] = Traits(
        "image", rows=2, value_columns=7, fixes_frame=False, fixes_scale=True, sigma_unit="px"
    )
    """It fixes no frame: the images are of the tool in the camera's frame, and the camera's pose is unknown, so
    moving the base and the camera together changes no pixel (as a tracker whose place is not known). Its pose is
    identified and the base held, as for the other references. The markers' known spacing gives the length."""

    def __post_init__(self) -> None:
        self.intrinsics.check(self.name)

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        group = f"camera.{self.name}"
        return (
            *position_specs(group, np.asarray(self.position)),
            *(ParameterSpec(f"{group}.r{axis}", group, Kind.ANGLE, 0.0, ANGLE_SCALE_RAD) for axis in "xyz"),
        )

    @property
    def minimum_records(self) -> int:
        return 6  # points: the closed-form start (a DLT) needs six, and 12 rows over-determine the 6 unknowns

    def orientation(self, w: Array) -> Array:
        """R_c = exp([ω]×) R₀: the camera's orientation in its parent frame."""
        return np.asarray(rotvec_to_matrix_np(w) @ rotvec_to_matrix_np(np.asarray(self.rotation)))

    def in_parent(self, positions: Array, rotations: Array, targets: Array) -> Array:
        """The target points in the camera's parent frame (the world): y = R m + p."""
        return np.asarray(np.einsum("nij,nj->ni", rotations, targets) + positions)

    def parent_jacobian(self, tcp: ForwardJacobianResult, targets: Array) -> Array:
        """∂y/∂θ (n, 3, P) = ∂p/∂θ − [R m]× ∂ω/∂θ (dR = [dω]× R)."""
        lever = np.einsum("nij,nj->ni", tcp.rotations, targets)
        return np.asarray(tcp.jacobians[:, :3, :] - skew(lever) @ tcp.jacobians[:, 3:, :])

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        targets, pixels = values[:, 2:5], values[:, 5:7]
        y = self.in_parent(tcp.positions, tcp.rotations, targets)
        rc = self.orientation(u[3:6])
        offset = y - u[:3]
        x_cam = offset @ rc  # each row R_cᵀ (y − t)
        projected, d_pixel = self.intrinsics.project(x_cam)
        to_camera = d_pixel @ rc.T  # ∂(u, v)/∂y
        d_theta = to_camera @ self.parent_jacobian(tcp, targets)
        d_position = -to_camera
        d_rotation = to_camera @ skew(offset) @ left_jacobian(u[3:6])  # ∂X/∂ω = R_cᵀ [y − t]× J_l(ω)
        return projected - pixels, d_theta, np.concatenate([d_position, d_rotation], axis=2)

    def errors_mm(self, tcp: ForwardResult, u: Array, values: Array) -> Array:
        """Each point's reprojection error carried to its depth (px · Z / f, mm): what the pixels say the point
        misses by, in the units every other record's error is stated in."""
        targets, pixels = values[:, 2:5], values[:, 5:7]
        x_cam = (self.in_parent(tcp.positions, tcp.rotations, targets) - u[:3]) @ self.orientation(u[3:6])
        projected, _ = self.intrinsics.project(x_cam)
        focal = np.array([self.intrinsics.fx, self.intrinsics.fy])
        return np.asarray(np.linalg.norm((projected - pixels) * x_cam[:, 2:3] / focal, axis=1))

    def started(self, tcp: ForwardResult, values: Array) -> Camera:
        """Its pose from the records under the start model (a DLT on the undistorted pixels, see
        `pose_from_points`), after the slips a camera file makes are ruled out."""
        targets, pixels = values[:, 2:5], values[:, 5:7]
        y = self.in_parent(tcp.positions, tcp.rotations, targets)
        rotation, position, misfit = self._pose(y, pixels)
        _, _, swapped = self._pose(y, pixels[:, ::-1])
        if misfit > SLIP_MISFIT_PX and swapped < SLIP_RATIO * misfit:
            raise InvalidInput(
                f"camera {self.name!r}: the pixels look like (v, u), not (u, v): with u and v swapped they fit to "
                f"{swapped:.3g} px, as given to {misfit:.3g} px (median); give each pixel as [u, v] (u across the "
                "image, v down it)",
                field="measurements",
                reason="pixel_order",
            )
        if misfit > CANNOT_FIT_PX:
            raise InvalidInput(
                f"camera {self.name!r}: no pose of this camera projects the points onto their pixels (they misfit "
                f"by {misfit:.3g} px, median): check that fx, fy, cx, cy are in pixels, that the points are given "
                f"in the {self.seen_frame} frame in mm, and each record's joints",
                field=f"cameras.{self.name}",
                reason="projection_misfit",
            )
        self._in_front(y, rotation, position, values)
        rx, ry, rz = (float(v) for v in matrix_to_rotvec_np(rotation))
        x, y_, z = (float(v) for v in position)
        return type(self)(self.name, self.intrinsics, (x, y_, z), (rx, ry, rz))

    def _pose(self, y: Array, pixels: Array) -> tuple[Array, Array, float]:
        """(R_c, t, the median reprojection misfit in px) of the closed-form pose."""
        rotation, position = pose_from_points(y, self.intrinsics.normalised(pixels))
        projected, _ = self.intrinsics.project((y - position) @ rotation)
        misfit = np.linalg.norm(projected - pixels, axis=1)
        return rotation, position, float(np.median(np.where(np.isfinite(misfit), misfit, np.inf)))

    def _in_front(self, y: Array, rotation: Array, position: Array, values: Array) -> None:
        depth = ((y - position) @ rotation)[:, 2]
        behind = np.flatnonzero(depth <= 0)
        if behind.size:
            k = int(behind[0])
            image, point = int(values[k, 0]), int(values[k, 1])
            raise InvalidInput(
                f"camera {self.name!r}: image {image}, point {point} is behind the camera (at {depth[k]:.4g} mm along "
                f"its axis, at the pose the images give; {behind.size} such points): a camera cannot have seen it, "
                "so its pixel belongs to another point or its target is given wrongly",
                field="measurements",
                reason="behind_camera",
                value=k,
            )


@dataclass(frozen=True)
class ToolCamera(Camera):
    """A camera on the tool (hand-eye) seeing points given in the world frame (a board in the cell); its pose is
    in the tool (TCP) frame."""

    mount: ClassVar[str] = "tool"
    seen_frame: ClassVar[str] = "world (the robot's base placed in it to within millimetres)"
    traits: ClassVar[Traits] = Traits(
        "image", rows=2, value_columns=7, fixes_frame=True, fixes_scale=True, sigma_unit="px"
    )
    """It fixes the frame: the board's points are given in the world frame, so its images see the robot's base
    relative to them, and the base is identified. What it cannot see is the constant transform after the last
    joint (the last link's constants and the tool's): only its product with the hand-eye reaches the pixels,
    and the identifiability analysis holds those parameters, keeping the camera's (the references' unknowns
    come first)."""

    def in_parent(self, positions: Array, rotations: Array, targets: Array) -> Array:
        """The board's points in the tool frame: y = Rᵀ (b − p)."""
        return np.asarray(np.einsum("nji,nj->ni", rotations, targets - positions))

    def parent_jacobian(self, tcp: ForwardJacobianResult, targets: Array) -> Array:
        """∂y/∂θ = Rᵀ ([b − p]× ∂ω/∂θ − ∂p/∂θ)."""
        lever = targets - tcp.positions
        world = skew(lever) @ tcp.jacobians[:, 3:, :] - tcp.jacobians[:, :3, :]
        return np.asarray(np.transpose(tcp.rotations, (0, 2, 1)) @ world)


def pose_from_points(y: Array, normalised: Array) -> tuple[Array, Array]:
    """(R_c, t): the pose of a camera that sees the points y (n, 3, its parent frame; not all on a plane) at
    the undistorted normalised coordinates (n, 2), in closed form.

    A DLT: with X = A y + b the camera-frame point, x' X₃ = X₁ and y' X₃ = X₂ are linear in P = [A | b] (12
    numbers, up to scale): P is the singular vector of the least singular value, on points centred and scaled
    for conditioning. A is then a rotation times the scale: the nearest rotation (by its SVD, the determinant
    kept +1) and the mean singular value give R_c = Aᵀ and t = −R_c b, the sign chosen so that the points lie in
    front."""
    centre = y.mean(axis=0)
    spread = float(np.sqrt(np.mean(np.sum((y - centre) ** 2, axis=1)))) or 1.0
    h = np.hstack([(y - centre) / spread, np.ones((y.shape[0], 1))])
    zeros = np.zeros_like(h)
    rows = np.vstack(
        [
            np.hstack([h, zeros, -normalised[:, :1] * h]),
            np.hstack([zeros, h, -normalised[:, 1:] * h]),
        ]
    )
    p = np.linalg.svd(rows, full_matrices=False)[2][-1].reshape(3, 4)
    if np.median(h @ p[2]) < 0:
        p = -p
    u, s, vt = np.linalg.svd(p[:, :3])
    a = u @ np.diag([1.0, 1.0, float(np.linalg.det(u @ vt))]) @ vt
    b = p[:, 3] / s.mean() * spread - a @ centre  # X = A (y − c)/spread · spread + b' spread
    rotation = a.T
    return rotation, -rotation @ b


MOUNTS: dict[str, type[Camera]] = {"world": Camera, "tool": ToolCamera}


def read_images(
    cameras: Mapping[str, Mapping[str, Any]], images: Sequence[Mapping[str, Any]], *, sigma_px: float = 0.1
) -> tuple[ReferenceRecords, ...]:
    """The records of `images` (the contract's `{"kind": "image", "joints", "camera", "points": [{"target_mm",
    "pixel"}, ...], "sigma_px"?}`, joints in internal units) against `cameras` (`{"fx", "fy", "cx", "cy",
    "distortion"?, "mount"}` by name): one group per camera that is seen, one record per point (see the module
    docstring); `sigma_px` where an image states none. An InvalidInput names the field of every slip."""
    described = {name: described_camera(name, spec) for name, spec in cameras.items()}
    seen: dict[str, list[tuple[Array, Array, Array]]] = {}
    for i, image in enumerate(images):
        name = image.get("camera")
        if name not in described:
            raise InvalidInput(
                f"image {i} is of camera {name!r}, which is not described: describe it under cameras (its fx, fy, "
                "cx, cy and mount)",
                field=f"measurements[{i}].camera",
                reason="unknown_camera",
                value=str(name),
                allowed=sorted(described),
            )
        seen.setdefault(str(name), []).append(_image_rows(i, image, sigma_px))
    groups = []
    for name, rows in seen.items():
        joints, values, sigma = (np.concatenate([r[k] for r in rows]) for k in range(3))
        groups.append(ReferenceRecords(described[name], joints, values, sigma))
    return tuple(groups)


def described_camera(name: str, spec: Mapping[str, Any]) -> Camera:
    """The camera of the contract's description (`{"fx", "fy", "cx", "cy", "distortion"?, "width"?, "height"?,
    "mount"}`; other keys are not read), at the start pose (0, 0, 0): a fit finds its pose, a design places it."""
    mount = spec.get("mount", "world")
    if mount not in MOUNTS:
        raise InvalidInput(
            f"camera {name!r}: mount {mount!r} is not one of {sorted(MOUNTS)}",
            field=f"cameras.{name}.mount",
            reason="mount",
            allowed=sorted(MOUNTS),
        )
    distortion = tuple(float(v) for v in spec.get("distortion", (0.0,) * 5))
    if len(distortion) != 5:
        raise InvalidInput(
            f"camera {name!r}: distortion is OpenCV's five [k1, k2, p1, p2, k3], got {len(distortion)} numbers",
            field=f"cameras.{name}.distortion",
            reason="intrinsics",
        )
    k1, k2, p1, p2, k3 = distortion
    size = {k: float(spec[k]) for k in ("width", "height") if spec.get(k) is not None}
    numbers = {k: float(spec[k]) for k in ("fx", "fy", "cx", "cy")}
    return MOUNTS[mount](name, Intrinsics(**numbers, distortion=(k1, k2, p1, p2, k3), **size))


def _image_rows(i: int, image: Mapping[str, Any], default_sigma: float) -> tuple[Array, Array, Array]:
    """(joints, values, σ) of one image's points, one row each."""
    points = image.get("points") or []
    if not points:
        raise InvalidInput(
            f"image {i} (camera {image.get('camera')!r}) sees no point: give the points it saw, or leave it out",
            field=f"measurements[{i}].points",
            reason="camera_sees_nothing",
        )
    sigma = float(image.get("sigma_px", default_sigma))
    if not (np.isfinite(sigma) and sigma > 0):
        raise InvalidInput(f"image {i}: sigma_px must be a positive number", field=f"measurements[{i}].sigma_px")
    try:
        values = np.array([[i, k, *point["target_mm"], *point["pixel"]] for k, point in enumerate(points)], dtype=float)
    except (KeyError, TypeError, ValueError):
        values = np.zeros((0, 0))  # a point without both, or of other lengths: refused below
    if values.ndim != 2 or values.shape[1] != 7 or not np.all(np.isfinite(values)):
        raise InvalidInput(
            f"image {i}: each point is {{target_mm: [x, y, z], pixel: [u, v]}}, finite numbers",
            field=f"measurements[{i}].points",
            reason="point_shape",
        )
    joints = np.tile(np.asarray(image["joints"], dtype=float), (len(points), 1))
    return joints, values, np.full(len(points), sigma)
