"""The baseline's model: a serial arm's forward kinematics in plain numpy, as a scipy user writes it.

The same kinematics as the service's (`T = base · Π A_i · tool`, standard DH `Rz(θ)·Tz(d)·Tx(a)·Rx(α)` or
Craig's MDH `Rx(α)·Ry(β)·Tx(a)·Rz(θ)·Tz(d)`, base and tool as position + rotation vector), written from the
textbook definitions and taking the service's parameter vector, so that the benchmark can check it equals the
compiled model numerically before it times anything. Two forms:

- `PerPoseArm`: pybotics' documented calibration recipe (`compute_absolute_errors`): one 4×4 forward
  kinematics per pose in a Python loop, the errors stacked;
- `VectorisedArm`: every pose at once ((N, 4, 4) products per link): the fastest a numpy user gets without
  writing a compiled model, the harder baseline.

Nothing here imports the service's symbolic model or its compiled Functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription


def _rodrigues(v: Array) -> Array:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3)."""
    angle = np.linalg.norm(v, axis=-1)[..., None, None]
    safe = np.where(angle > 1e-12, angle, 1.0)
    k = v[..., :, None] / safe[..., 0]
    kx = np.zeros((*v.shape[:-1], 3, 3))
    kx[..., 0, 1], kx[..., 0, 2], kx[..., 1, 2] = -k[..., 2, 0], k[..., 1, 0], -k[..., 0, 0]
    kx[..., 1, 0], kx[..., 2, 0], kx[..., 2, 1] = k[..., 2, 0], -k[..., 1, 0], k[..., 0, 0]
    eye = np.broadcast_to(np.eye(3), kx.shape)
    rot = eye + np.sin(angle) * kx + (1.0 - np.cos(angle)) * (kx @ kx)
    return np.where(angle > 1e-12, rot, eye)


def _frame(p6: Array) -> Array:
    t = np.eye(4)
    t[:3, :3] = _rodrigues(p6[3:])
    t[:3, 3] = p6[:3]
    return t


@dataclass(frozen=True)
class _Layout:
    """Where each link's parameters sit in the service's vector, and how its joint enters."""

    base: slice
    tool: slice
    links: tuple[tuple[bool, bool, int, int, int, int, int | None, int | None], ...]
    """(mdh, revolute, θ, d, a, α, β or None, joint column or None) per link."""

    @classmethod
    def of(cls, desc: RobotDescription) -> _Layout:
        if desc.has_closure:
            raise ValueError("the numpy baseline models serial arms only")
        index = desc.parameters.index
        rows = []
        k = 0
        for i, link in enumerate(desc.links, start=1):
            moves = link.joint.moves
            rows.append(
                (
                    link.convention.value == "mdh",
                    link.joint.value == "revolute",
                    index[f"link{i}.theta"],
                    index[f"link{i}.d"],
                    index[f"link{i}.a"],
                    index[f"link{i}.alpha"],
                    index.get(f"link{i}.beta"),
                    k if moves else None,
                )
            )
            k += moves
        return cls(desc.slices["base"], desc.slices["tool"], tuple(rows))


class PerPoseArm:
    """pybotics' recipe: forward kinematics one pose at a time."""

    def __init__(self, desc: RobotDescription) -> None:
        self.layout = _Layout.of(desc)

    def fk(self, q: Array, theta: Array) -> Array:
        lay = self.layout
        t = _frame(theta[lay.base])
        for mdh, revolute, i_th, i_d, i_a, i_al, i_be, col in lay.links:
            th, d, a, al = theta[i_th], theta[i_d], theta[i_a], theta[i_al]
            if col is not None:
                if revolute:
                    th = th + q[col]
                else:
                    d = d + q[col]
            ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(al), np.sin(al)
            if mdh:
                be = 0.0 if i_be is None else theta[i_be]
                cb, sb = np.cos(be), np.sin(be)
                rx = np.array([[1, 0, 0, 0], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
                ry = np.array([[cb, 0, sb, 0], [0, 1, 0, 0], [-sb, 0, cb, 0], [0, 0, 0, 1.0]])
                rest = np.array([[ct, -st, 0, a], [st, ct, 0, 0], [0, 0, 1, d], [0, 0, 0, 1.0]])
                t = t @ rx @ ry @ rest
            else:
                t = t @ np.array(
                    [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]]
                )
        return np.asarray(t @ _frame(theta[lay.tool]))

    def positions(self, joints: Array, theta: Array) -> Array:
        return np.array([self.fk(q, theta)[:3, 3] for q in joints])


class VectorisedArm:
    """The same model over all poses at once."""

    def __init__(self, desc: RobotDescription) -> None:
        self.layout = _Layout.of(desc)

    def positions(self, joints: Array, theta: Array) -> Array:
        return np.asarray(self.poses(joints, theta)[:, :3, 3])

    def poses(self, joints: Array, theta: Array) -> Array:
        """(N, 4, 4) TCP transforms."""
        lay = self.layout
        n = joints.shape[0]
        t = np.broadcast_to(_frame(theta[lay.base]), (n, 4, 4))
        for mdh, revolute, i_th, i_d, i_a, i_al, i_be, col in lay.links:
            th = np.full(n, theta[i_th])
            d = np.full(n, theta[i_d])
            if col is not None:
                if revolute:
                    th = th + joints[:, col]
                else:
                    d = d + joints[:, col]
            a, al = theta[i_a], theta[i_al]
            ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(al), np.sin(al)
            m = np.zeros((n, 4, 4))
            m[:, 3, 3] = 1.0
            if mdh:
                be = 0.0 if i_be is None else theta[i_be]
                cb, sb = np.cos(be), np.sin(be)
                fixed = np.array(
                    [[cb, 0, sb, a * cb], [sa * sb, ca, -sa * cb, a * sa * sb], [-ca * sb, sa, ca * cb, -a * ca * sb]]
                )
                # Rx(α)·Ry(β)·Tx(a) is constant per link; Rz(θ)·Tz(d) carries the joint.
                m[:, 0, 0], m[:, 0, 1], m[:, 1, 0], m[:, 1, 1], m[:, 2, 2], m[:, 2, 3] = ct, -st, st, ct, 1.0, d
                head = np.eye(4)
                head[:3, :] = fixed
                m = head @ m
            else:
                m[:, 0, 0], m[:, 0, 1], m[:, 0, 2], m[:, 0, 3] = ct, -st * ca, st * sa, a * ct
                m[:, 1, 0], m[:, 1, 1], m[:, 1, 2], m[:, 1, 3] = st, ct * ca, -ct * sa, a * st
                m[:, 2, 1], m[:, 2, 2], m[:, 2, 3] = sa, ca, d
            t = t @ m
        return np.asarray(t @ _frame(theta[lay.tool]))
