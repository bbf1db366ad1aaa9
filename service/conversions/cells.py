"""A cell document (mm, degrees) as the models' `Cell` (mm, radians), and the effective cell back for its page."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, TypedDict

import numpy as np

from models import RobotDescription
from models._types import Pose6, Vec3
from models.cell import (
    Attached,
    Ballbar,
    Box,
    Camera,
    Capsule,
    Cell,
    Cylinder,
    FrameLayout,
    Mesh,
    Obstacle,
    Pair,
    RobotGeometry,
    Segment,
    Shape,
    Sphere,
    Target,
    Tracker,
    default_allowed,
    default_geometry,
    frame_layout,
    pair,
    urdf_geometry,
)
from models.cell.geometry import LinkShape
from models.description.structure import description_from_document
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.formats.urdf import UrdfSource, document_from_urdf
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from service.persistence.tables import RobotCellRecord
from service.schemas.cells import (
    AllowedPairPublic,
    BoxShape,
    CameraDocument,
    CapsuleShape,
    CellDocument,
    CellPublic,
    CellShapePublic,
    CellVersionPublic,
    CylinderShape,
    MeshShape,
    Placed,
    SphereShape,
    TargetDocument,
    TrackerDocument,
)
from service.schemas.common import timestamp


@dataclass(frozen=True)
class EffectiveCell:
    """The models' cell of a document on a robot, and why each allowed pair is allowed."""

    cell: Cell
    why: dict[Pair, str]
    layout: FrameLayout


def _vec(values: list[float]) -> Vec3:
    return (float(values[0]), float(values[1]), float(values[2]))


def _pose6(placed: Placed) -> Pose6:
    r = np.radians(np.asarray(placed.rotation_vector_deg, dtype=float))
    return (*_vec(placed.position_mm), float(r[0]), float(r[1]), float(r[2]))


def _matrix(placed: Placed) -> tuple[tuple[float, ...], ...]:
    m = np.eye(4)
    m[:3, :3] = rotvec_to_matrix_np(np.radians(np.asarray(placed.rotation_vector_deg, dtype=float)))
    m[:3, 3] = placed.position_mm
    return tuple(tuple(float(v) for v in row) for row in m)


def shape_in(solid: BoxShape | CylinderShape | SphereShape | CapsuleShape | MeshShape) -> Shape:
    if isinstance(solid, BoxShape):
        return Box(*(float(v) for v in solid.size_mm))
    if isinstance(solid, CylinderShape):
        return Cylinder(solid.radius_mm, solid.length_mm)
    if isinstance(solid, SphereShape):
        return Sphere(solid.radius_mm)
    if isinstance(solid, CapsuleShape):
        return Capsule(solid.radius_mm, solid.length_mm)
    return Mesh.of(np.asarray(solid.vertices_mm, dtype=float), np.asarray(solid.faces, dtype=int))


def _target(doc: TargetDocument) -> Target:
    return Target(offset=_vec(doc.offset_mm), facing=_vec(doc.facing))


def robot_geometry(desc: RobotDescription, source: UrdfSource | None) -> RobotGeometry:
    """A URDF robot's collision shapes where its URDF has any, otherwise the capsules of its link lengths.

    The URDF's shapes are placed on the URDF's own model (world = its base_link): each is rigid in a link
    frame, which the robot's description shares whatever base the robot was given around it."""
    if source is not None:
        own = description_from_document(document_from_urdf(source.urdf, source.base_link, source.tip_link))
        found = urdf_geometry(own, source.urdf, source.base_link, source.tip_link)
        if any(s.body != "tool" for s in found.shapes):
            return found
    return default_geometry(desc)


def _body_frame(layout: FrameLayout, body: str, frame: str | None) -> str:
    """The frame an override's shapes are given in: `frame`, which must move with `body`, or the body's last."""
    frames = [name for name, owner in zip(layout.names, layout.bodies, strict=True) if owner == body]
    if frame is None:
        return frames[-1]
    if frame not in frames:
        raise InvalidInput(
            f"links.{body}.frame: {frame!r} does not move with {body} (its frames: {', '.join(frames)})",
            field=f"links.{body}.frame",
        )
    return frame


def _overridden(geometry: RobotGeometry, doc: CellDocument, layout: FrameLayout) -> RobotGeometry:
    shapes: list[LinkShape] = list(geometry.shapes)
    for body, override in doc.links.items():
        if body not in layout.body_order:
            raise InvalidInput(
                f"links: {body!r} is not a body of this robot ({', '.join(layout.body_order)})", field="links"
            )
        if override.capsule_radius_mm is not None:
            if not any(isinstance(s, Segment) and s.body == body for s in shapes):
                raise InvalidInput(
                    f"links.{body}: it has no capsule to resize (its shapes are a URDF's): give shapes instead",
                    field=f"links.{body}.capsule_radius_mm",
                )
            radius = float(override.capsule_radius_mm)
            shapes = [replace(s, radius=radius) if isinstance(s, Segment) and s.body == body else s for s in shapes]
            continue
        assert override.shapes is not None  # the schema asks for one of the two
        frame = _body_frame(layout, body, override.frame)
        own: list[LinkShape] = [Attached(body, frame, shape_in(s), _matrix(s)) for s in override.shapes]
        shapes = [s for s in shapes if s.body != body] + own
    out = RobotGeometry(tuple(shapes), geometry.source, geometry.skipped)
    out.check(layout)
    return out


class _Sight(TypedDict):
    """What a tracker and a camera both see a target within: its distance (mm) and the cone it must face the
    instrument within (its half-angle, rad)."""

    range_min: float
    range_max: float
    acceptance: float


def _sight(instrument: TrackerDocument | CameraDocument) -> _Sight:
    return _Sight(
        range_min=instrument.range_min_mm,
        range_max=instrument.range_max_mm,
        acceptance=float(np.radians(instrument.acceptance_deg)),
    )


def _instruments(doc: CellDocument) -> tuple[Tracker | None, Camera | None, Ballbar | None]:
    tracker = camera = ballbar = None
    if doc.tracker is not None:
        t = doc.tracker
        tracker = Tracker(
            _vec(t.position_mm), **_sight(t), reflector=_target(t.reflector), beam_clearance=t.beam_clearance_mm
        )
    if doc.camera is not None:
        c = doc.camera
        camera = Camera(
            _pose6(c),
            half_width=float(np.radians(c.half_width_deg)),
            half_height=float(np.radians(c.half_height_deg)),
            **_sight(c),
            target=_target(c.target),
            sight_clearance=c.sight_clearance_mm,
        )
    if doc.ballbar is not None:
        bar = doc.ballbar
        ballbar = Ballbar(_vec(bar.pivot_mm), bar.length_min_mm, bar.length_max_mm, _vec(bar.tcp_offset_mm))
    return tracker, camera, ballbar


def cell_in(
    desc: RobotDescription, doc: CellDocument, source: UrdfSource | None, runtime: Runtime | None = None
) -> EffectiveCell:
    """The models' cell: the robot's geometry with the document's overrides, its obstacles and instruments in
    internal units, and the default allowed pairs (`models.cell.default_allowed`) with the document's own."""
    layout = frame_layout(desc)
    geometry = _overridden(robot_geometry(desc, source), doc, layout)
    obstacles = tuple(Obstacle(o.name, shape_in(o), _pose6(o)) for o in doc.obstacles)
    why = default_allowed(desc, geometry, obstacles, doc.clearance_mm, runtime=runtime)
    for first, second in doc.allowed:
        why.setdefault(pair(first, second), "given")
    tracker, camera, ballbar = _instruments(doc)
    cell = Cell(geometry, obstacles, tracker, camera, ballbar, doc.clearance_mm, frozenset(why))
    return EffectiveCell(cell, why, layout)


def _solid_out(shape: Shape) -> dict[str, Any]:
    if isinstance(shape, Box):
        return {"kind": "box", "size_mm": [shape.x, shape.y, shape.z]}
    if isinstance(shape, Cylinder):
        return {"kind": "cylinder", "radius_mm": shape.radius, "length_mm": shape.length}
    if isinstance(shape, Sphere):
        return {"kind": "sphere", "radius_mm": shape.radius}
    if isinstance(shape, Capsule):
        return {"kind": "capsule", "radius_mm": shape.radius, "length_mm": shape.length}
    return {"kind": "mesh"}


def _shape_out(shape: LinkShape, origin: str) -> CellShapePublic:
    if isinstance(shape, Segment):
        return CellShapePublic.model_validate(
            {
                "body": shape.body,
                "origin": origin,
                "kind": "capsule",
                "radius_mm": shape.radius,
                "from_frame": shape.frame_a,
                "to_frame": shape.frame_b,
                "from_point_mm": list(shape.a),
                "to_point_mm": list(shape.b),
            }
        )
    m = shape.matrix
    placed = {
        "position_mm": m[:3, 3].tolist(),
        "rotation_vector_deg": np.degrees(matrix_to_rotvec_np(m[:3, :3])).tolist(),
    }
    fields = {"body": shape.body, "origin": origin, "frame": shape.frame, **_solid_out(shape.shape), **placed}
    return CellShapePublic.model_validate(fields)


def cell_public(robot_id: str, record: RobotCellRecord, effective: EffectiveCell) -> CellPublic:
    assert record.document is not None  # an ended version has no page (the routes answer 404)
    doc = CellDocument.model_validate(record.document)
    geometry = effective.cell.geometry

    def origin(shape: LinkShape) -> str:
        if shape.body in doc.links:
            return "override"
        return "urdf" if isinstance(shape, Attached) else "default"

    shapes = [_shape_out(s, origin(s)) for s in geometry.shapes]
    allowed = [
        AllowedPairPublic(solids=sorted(p) if len(p) == 2 else [*p, *p], why=why)
        for p, why in sorted(effective.why.items(), key=lambda item: sorted(item[0]))
    ]
    return CellPublic.model_validate(
        {
            "robot_id": robot_id,
            "version": record.version,
            "created_at": timestamp(record.created_at),
            "actor": record.actor,
            "cell": doc,
            "geometry_source": geometry.source,
            "geometry": shapes,
            "frames": list(effective.layout.names),
            "skipped": list(geometry.skipped),
            "allowed": allowed,
        }
    )


def cell_version_out(record: RobotCellRecord) -> CellVersionPublic:
    doc = record.document or {}
    instruments = [k for k in ("tracker", "camera", "ballbar") if doc.get(k) is not None]
    return CellVersionPublic.model_validate(
        {
            "version": record.version,
            "created_at": timestamp(record.created_at),
            "actor": record.actor,
            "ended": record.document is None,
            "obstacles": len(doc.get("obstacles", [])),
            "instruments": instruments,
        }
    )
