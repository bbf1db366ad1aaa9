"""A URDF's `<collision>` shapes on the model's frames (see `urdf_geometry`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from models._types import Array
from models.cell.frames import frame_layout, stage_frames
from models.cell.geometry import TOOL_RADIUS, Attached, LinkShape, RobotGeometry, Segment
from models.cell.shapes import Box, Cylinder, Shape, Sphere
from models.description.robot import RobotDescription
from models.formats.urdf import load_urdf, origin_mm, urdf_chain

MM_PER_M = 1000.0


def urdf_geometry(desc: RobotDescription, urdf: str, base_link: str, tip_link: str) -> RobotGeometry:
    """The `<collision>` boxes, cylinders and spheres of the URDF's links from `base_link` to `tip_link`, attached
    to `desc`'s frames (`desc` is `document_from_urdf(urdf, base_link, tip_link)`'s robot, maybe calibrated).

    A URDF link moves with the last moving joint above it (link k's body; `base` above the first), and its
    shapes are rigid in that body's end frame: the pose there is inv(frame_k(0)) · (base_link <- URDF link at
    q = 0), both at the zero joint vector, where the model's FK equals the URDF's (`models.formats.urdf`). Meshes
    name files this service is not given (`package://` paths): they are listed in `skipped`, not guessed.
    The tool capsule (last frame -> TCP) is added as for a DH document."""
    path = urdf_chain(urdf, base_link, tip_link)
    layout = frame_layout(desc)
    zero = np.zeros((1, desc.n_joints))
    model_frames = stage_frames(desc, zero)[0]
    world = np.eye(4)
    placed: list[tuple[Any, Array, str]] = []  # (URDF link, base_link <- link at q = 0, body frame)
    robot_links = _links_by_name(urdf)
    placed.append((robot_links[base_link], world.copy(), "base"))
    moving = 0
    for joint in path:
        world = world @ origin_mm(joint)
        if joint.type != "fixed":
            moving += 1
        placed.append((robot_links[joint.child], world.copy(), "base" if moving == 0 else f"link{moving}"))
    shapes: list[LinkShape] = []
    skipped: list[str] = []
    for link, at_zero, frame in placed:
        offset = np.linalg.solve(model_frames[layout.index(frame)], at_zero)
        for c in link.collisions:
            local = np.eye(4) if c.origin is None else np.asarray(c.origin, dtype=float).copy()
            local[:3, 3] *= MM_PER_M
            g = c.geometry
            shape: Shape
            if g.box is not None:
                sx, sy, sz = (MM_PER_M * float(v) for v in g.box.size)
                shape = Box(sx, sy, sz)
            elif g.cylinder is not None:
                shape = Cylinder(MM_PER_M * float(g.cylinder.radius), MM_PER_M * float(g.cylinder.length))
            elif g.sphere is not None:
                shape = Sphere(MM_PER_M * float(g.sphere.radius))
            else:
                name = g.mesh.filename if g.mesh is not None else "an empty geometry"
                skipped.append(f"{link.name}: {name}")
                continue
            pose = offset @ local
            shapes.append(Attached(frame if frame != "base" else "base", frame, shape, _rows(pose)))
    last = layout.names[-2]
    shapes.append(Segment("tool", last, "tcp", TOOL_RADIUS))
    geometry = RobotGeometry(tuple(shapes), "urdf", tuple(skipped))
    geometry.check(layout)
    return geometry


def _links_by_name(urdf: str) -> dict[str, Any]:
    return {link.name: link for link in load_urdf(urdf).links}


def _rows(m: Array) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in m)
