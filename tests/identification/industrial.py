"""An industrial 6R arm (ABB IRB 2400-sized standard DH table) and an independent numpy model of it.

The link lengths are ROS-Industrial's `abb_irb2400_support` URDF's joint origins (joint_2 at 100 mm out and 615 mm
up, 705 mm to joint_3, 135 mm to the wrist's axis, 755 mm along it, 85 mm to the flange), written as a standard
DH table. The numpy model (`fk`, `reference_fit`) shares no code with `models`: it is the yardstick the issue's
"independent scipy fit of the same model on the same split" asks for.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.optimize
from scipy.spatial.transform import Rotation

from models import RobotDescription
from models.description.structure import description_from_document

Array = np.ndarray

IRB2400_DH = ((100.0, -90.0, 615.0, 0.0), (705.0, 0.0, 0.0, -90.0), (135.0, -90.0, 0.0, 0.0),
              (0.0, 90.0, 755.0, 0.0), (0.0, -90.0, 0.0, 0.0), (0.0, 0.0, 85.0, 0.0))  # fmt: skip
"""(a, alpha, d, theta offset) per link, mm and degrees."""

TOOL_MM = (20.0, -30.0, 150.0)
"""A reflector off the flange's axis (on the axis, joint 6 would not move it)."""


def irb2400_document(tool: tuple[float, float, float] = TOOL_MM) -> dict[str, Any]:
    links = [
        {"joint": "revolute", "a": a, "alpha": al, "d": d, "theta": th, "range": [-360.0, 360.0]}
        for a, al, d, th in IRB2400_DH
    ]
    pose = {"position": list(tool), "orientation": [1.0, 0.0, 0.0, 0.0]}
    return {"tool": pose, "stages": [{"kind": "serial", "convention": "dh", "links": links}]}


def irb2400_like(tool: tuple[float, float, float] = TOOL_MM) -> RobotDescription:
    return description_from_document(irb2400_document(tool), name="irb2400-like")


# The numpy model: p = base · Π DH(q_i + θ_i, d_i, a_i, α_i) · tool, with base = (translation, rotation vector).
N_REFERENCE = 6 + 4 * 6 + 3
"""Base (x, y, z, rotation vector), per link (θ offset, d, a, α), tool (x, y, z)."""


def _dh(theta: Array, d: float, a: float, alpha: float) -> Array:
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    n = theta.size
    t = np.zeros((n, 4, 4))
    t[:, 0, 0], t[:, 0, 1], t[:, 0, 2], t[:, 0, 3] = ct, -st * ca, st * sa, a * ct
    t[:, 1, 0], t[:, 1, 1], t[:, 1, 2], t[:, 1, 3] = st, ct * ca, -ct * sa, a * st
    t[:, 2, 1], t[:, 2, 2], t[:, 2, 3] = sa, ca, d
    t[:, 3, 3] = 1.0
    return t


def reference_nominal(tool: tuple[float, float, float] = TOOL_MM) -> Array:
    links = [v for a, al, d, th in IRB2400_DH for v in (np.radians(th), d, a, np.radians(al))]
    return np.asarray(np.r_[np.zeros(6), links, tool], dtype=float)


def fk(x: Array, q: Array) -> Array:
    """TCP positions (N, 3) of the numpy model at joints `q` (radians)."""
    return fk_pose(x, q)[0]


def fk_pose(x: Array, q: Array) -> tuple[Array, Array]:
    """TCP positions (N, 3) and the flange's rotations (N, 3, 3) of the numpy model at joints `q`."""
    n = q.shape[0]
    t = np.tile(np.eye(4), (n, 1, 1))
    t[:, :3, :3] = Rotation.from_rotvec(x[3:6]).as_matrix()
    t[:, :3, 3] = x[:3]
    for i in range(6):
        th, d, a, al = x[6 + 4 * i : 10 + 4 * i]
        t = t @ _dh(q[:, i] + th, d, a, al)
    p = np.asarray(np.einsum("nij,j->ni", t[:, :3, :3], x[30:33]) + t[:, :3, 3])
    return p, t[:, :3, :3]


def reference_fit(q: Array, measured: Array, start: Array) -> Array:
    """scipy's least_squares ('trf', finite differences, its own defaults but a generous evaluation budget) of
    the numpy model to measured positions, from `start`. The redundant directions of the full DH table are left
    to 'trf' (they do not move any TCP)."""

    def residual(x: Array) -> Array:
        return np.asarray((fk(x, q) - measured).ravel())

    fit = scipy.optimize.least_squares(residual, start, method="trf", x_scale="jac", max_nfev=20000)
    return np.asarray(fit.x)


def register(q: Array, measured: Array, x: Array) -> Array:
    """`x` with its base moved onto the measured points (Kabsch on the positions): a start as any user has."""
    p = fk(x, q)
    pc, mc = p - p.mean(0), measured - measured.mean(0)
    u, _, vt = np.linalg.svd(pc.T @ mc)
    s = np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))])
    r = vt.T @ s @ u.T
    base = Rotation.from_matrix(r) * Rotation.from_rotvec(x[3:6])
    out = x.copy()
    out[3:6] = base.as_rotvec()
    out[:3] = r @ x[:3] + measured.mean(0) - r @ p.mean(0)
    return out


def straight_line_joints(
    start_mm: Array, end_mm: Array, n: int, *, x: Array, seed_joints: Array, rng: np.random.Generator
) -> Array:
    """Joints (N, 6) putting the numpy model's TCP at `n` random points of the segment start–end with the
    flange's orientation held (as a robot program's linear move does): inverse kinematics by continuation."""
    _, rot = fk_pose(x, seed_joints[None, :])
    held = rot[0]
    ts = np.sort(rng.uniform(0.0, 1.0, n))
    out, q = [], seed_joints.astype(float)
    for t in ts:
        goal = start_mm + t * (end_mm - start_mm)

        def miss(qq: Array, goal: Array = goal) -> Array:
            p, r = fk_pose(x, qq[None, :])
            return np.asarray(np.r_[p[0] - goal, 100.0 * (r[0] - held).ravel()])

        q = scipy.optimize.least_squares(miss, q, xtol=1e-14, ftol=1e-14, gtol=1e-14).x
        out.append(q)
    return np.array(out)
