"""Every stage's frames for a batch of joint vectors: world <- base, each link's middle and end, each parallel
stage's end (its platform), the TCP.

The forward kinematics of `models.engine.symbolic` give the TCP alone; collision checks need every link. The same
stage transforms (`Stage.transform`, the links' DH/MDH matrices) are multiplied here and every partial product
kept, in one CasADi Function built once per structure and kept by the structure's `Runtime`
(`runtime.artefact`), then mapped over the batch. A link's *middle* frame splits its two motions: for DH
Rz(θ)·Tz(d) (the joint's offset along the previous z), for MDH Rx(α)·Tx(a) (the common normal before the
joint); a link's default capsules run previous origin -> middle -> end, which follows the arm's metal for
either convention.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from models._types import Array
from models.description.robot import RobotDescription, pose_transform
from models.description.serial_chain import Convention, joint_link_values
from models.engine.batch import BatchFunctions
from models.engine.runtime import Runtime, runtime_for
from models.kinematics import solve_platforms
from models.stages import SerialStage
from models.transforms import homogeneous, rot_x, rot_y, rot_z

CHUNK = 2048
"""Poses per evaluation of the frames' Function."""


@dataclass(frozen=True)
class FrameLayout:
    """The frames' names in output order and the body each frame belongs to (what moves with it)."""

    names: tuple[str, ...]
    bodies: tuple[str, ...]
    """`base` for world <- {0}; `link{i}` for link i's middle and end frames; `stage{k}` for a parallel stage's
    end; `tool` for the TCP."""

    def index(self, name: str) -> int:
        return self.names.index(name)

    @property
    def body_order(self) -> tuple[str, ...]:
        """Bodies from base to tool, each once: neighbours in this order are adjacent."""
        return tuple(dict.fromkeys(self.bodies))


def frame_layout(desc: RobotDescription) -> FrameLayout:
    names, bodies = ["base"], ["base"]
    number = 1
    for k, stage in enumerate(desc.stages):
        if isinstance(stage, SerialStage):
            for _ in stage.links:
                names += [f"link{number}.mid", f"link{number}"]
                bodies += [f"link{number}", f"link{number}"]
                number += 1
        else:
            names.append(f"stage{k + 1}")
            bodies.append(f"stage{k + 1}")
    names.append("tcp")
    bodies.append("tool")
    return FrameLayout(tuple(names), tuple(bodies))


def _frames_function(desc: RobotDescription) -> ca.Function:
    q = ca.SX.sym("q", desc.n_joints)
    params = ca.SX.sym("params", desc.n_params)
    x = ca.SX.sym("platform", desc.n_platform)
    t = pose_transform(params[desc.slices["base"]])
    frames = [t]
    for stage, at in zip(desc.stages, desc.placements, strict=True):
        if not isinstance(stage, SerialStage):
            t = t @ stage.transform(q[at.joints], x[at.unknowns], params[at.params])
            frames.append(t)
            continue
        for link, theta, d, a, alpha, beta in joint_link_values(stage.links, q[at.joints], params[at.params]):
            rotation = rot_x(alpha) if beta is None else rot_x(alpha) @ rot_y(beta)
            if link.convention is Convention.DH:
                mid = homogeneous(rot_z(theta), ca.vertcat(0, 0, d))
                rest = homogeneous(rotation, ca.vertcat(a, 0, 0))
            else:
                mid = homogeneous(rotation, rotation @ ca.vertcat(a, 0, 0))
                rest = homogeneous(rot_z(theta), ca.vertcat(0, 0, d))
            frames.append(t @ mid)
            t = t @ mid @ rest
            frames.append(t)
    frames.append(t @ pose_transform(params[desc.slices["tool"]]))
    out = ca.vertcat(*[ca.vec(f[0:3, :]) for f in frames])  # 12 numbers a frame: R by columns, then p
    return ca.Function("stage_frames", [q, params, x], [out], ["q", "params", "platform"], ["frames"])


def _frames(desc: RobotDescription) -> BatchFunctions:
    """The Function behind `BatchFunctions.batch` (its buffer interface skips CasADi's slow DM conversion: a
    third of the check's time when it went through DM)."""
    f = _frames_function(desc)
    return BatchFunctions(functions={"stage_frames": f}, native={"stage_frames": f})


def stage_frames(
    desc: RobotDescription,
    joints: Array,
    params: Array | None = None,
    *,
    platforms: Array | None = None,
    runtime: Runtime | None = None,
) -> Array:
    """(N, F, 4, 4) world <- frame for each joint vector (all joints, internal units) and each frame of
    `frame_layout(desc)`. The closures' unknowns are solved here unless `platforms` are given."""
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.nominal if params is None else np.asarray(params, dtype=float)
    q = np.atleast_2d(np.asarray(joints, dtype=float))
    if q.shape[0] == 0:
        return np.zeros((0, len(frame_layout(desc).names), 4, 4))
    if platforms is None:
        platforms, _ = solve_platforms(desc, q, theta, runtime=rt)
    fns = rt.artefact("stage_frames", None, lambda: _frames(desc))
    # In chunks: a CasADi map is built per (padded) batch size, 0.3 s for tens of thousands of poses, while
    # chunks repeat a few sizes.
    flat = np.vstack(
        [
            fns.batch("stage_frames", q[at : at + CHUNK], theta, platforms[at : at + CHUNK])[0]
            for at in range(0, q.shape[0], CHUNK)
        ]
    )
    n = q.shape[0]
    blocks = flat.reshape(n, -1, 4, 3)  # each frame's [R | p] by columns
    frames = np.zeros((n, blocks.shape[1], 4, 4))
    frames[:, :, 0:3, 0:4] = np.swapaxes(blocks, 2, 3)
    frames[:, :, 3, 3] = 1.0
    return frames
