"""An image record: where a calibrated camera saw known points at these joints (its σ in px)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Annotated, Any, ClassVar, Literal, cast

import numpy as np
from pydantic import Field

from models import RobotDescription
from models.description.parameters import Kind
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.measurements.camera import Camera, described_camera, read_images
from models.measurements.references import ReferenceRecords
from models.transforms import matrix_to_rotvec_np
from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.records import length_factor
from service.conversions.kinematics import joints_in
from service.record_kinds.base import Described, FileRow, ModelReference, MustDescribe, RecordKind, cell, described_map
from service.schemas.common import JointVector, Position, Public, Strict
from service.schemas.references import CameraDescription, ReferenceName

SEEN_COLUMNS = ("x", "y", "z", "u", "v")
"""An image row's point (x, y, z in the frame it is given in) and its pixel (u, v)."""
IMAGE_COLUMN = "image"
"""Where present, it separates two images of one camera taken at the same joints."""
CAMERA_NEEDS = (
    (
        "position_mm",
        "a guess of where it is, mm, in its parent frame (the world; the tool for mount tool)",
        "[x, y, z]",
    ),
    (
        "rotation_vector_deg",
        "a guess of which way it looks: its frame's orientation in its parent frame as a rotation vector, deg "
        "(OpenCV's camera frame: z forward, x right, y down)",
        "[rx, ry, rz]",
    ),
    (
        "targets_mm",
        "the points it would see (markers in the tool frame for mount world, board points in the world frame for "
        "mount tool)",
        "[[x, y, z], ...]",
    ),
)

"""What a design needs of a camera that a calibration does not: which targets a pose shows, and where on the
image, depend on where the camera is."""
DEFAULT_SIGMA_PX = 0.1
"""A camera's σ where its description gives none: what a calibration assumes for an image that states none."""
_GROUPING = "_image"
"""The image id a record read from a file keeps until the file is read (`reference_table` drops it)."""


class SeenPoint(Strict):
    target_mm: Position = Field(
        description="The point in the frame the camera sees it in: the tool's (a world-mounted camera, markers on "
        "the tool) or the world's (a tool-mounted camera, a board in the cell)"
    )
    pixel: Annotated[list[Annotated[float, Field(ge=-1e5, le=1e5)]], Field(min_length=2, max_length=2)] = Field(
        description="[u, v] in px: u across the image, v down it (OpenCV's convention)"
    )


class ImageRecord(Strict):
    """Where a calibrated camera saw known points at these joints."""

    kind: Literal["image"]
    joints: JointVector
    camera: ReferenceName
    points: list[SeenPoint] = Field(min_length=1, max_length=10_000)
    sigma_px: float | None = Field(default=None, gt=0, le=100, description="Per pixel coordinate; default 0.1 px")


class SeenPointPublic(Public):
    target_mm: list[float]
    pixel: list[float]


class ImageRecordPublic(Public):
    kind: Literal["image"]
    joints: list[float]
    camera: str
    points: list[SeenPointPublic]
    sigma_px: float | None = None


class ImageKind(RecordKind):
    name: ClassVar[str] = "image"
    model: ClassVar[str] = Camera.traits.kind
    record = ImageRecord
    public = ImageRecordPublic
    named_by: ClassVar[str | None] = "camera"
    label: ClassVar[str] = "image"
    description = CameraDescription
    described_field: ClassVar[Any] = described_map(
        20,
        "Every camera an image record names, with its intrinsics; a pose design needs each one's "
        "position_mm, rotation_vector_deg (a guess of its pose) and targets_mm (what it would see), optionally "
        "sigma_px",
    )
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {
        "rotation_vector_deg": (
            list[float] | None,
            Field(
                default=None,
                description="A camera's orientation (camera frame → its parent frame) as a rotation vector",
            ),
        ),
    }
    example_name: ClassVar[str] = "c1"
    design_description: ClassVar[str] = (
        '{"fx": …, "fy": …, "cx": …, "cy": …, "position_mm": [x, y, z], "rotation_vector_deg": [rx, ry, rz], '
        '"targets_mm": [[x, y, z], …]}'
    )
    sampled: ClassVar[bool] = True
    unseen_filter: ClassVar[str | None] = "not_seen"
    must_describe: ClassVar[MustDescribe | None] = MustDescribe(
        "is an image of camera", '{"fx": …, "fy": …, "cx": …, "cy": …, "mount": "world"}', "its intrinsics in px"
    )
    file_columns: ClassVar[tuple[str, ...]] = (*SEEN_COLUMNS, "sigma_px")

    def design_has(self, have: int) -> str:
        return f"would see {have} targets over its candidate images"

    def design_reference(self, name: str, description: Any) -> ModelReference:
        """The described camera at the pose the body guesses for it."""
        for key, what, example in CAMERA_NEEDS:
            if getattr(description, key) is None:
                raise self.lacking(name, key, what, example)
        x, y, z = description.position_mm
        rx, ry, rz = (math.radians(v) for v in description.rotation_vector_deg)
        placed = described_camera(name, description.model_dump(exclude_none=True))
        return replace(placed, position=(x, y, z), rotation=(rx, ry, rz))

    def design_records(
        self,
        desc: RobotDescription,
        reference: ModelReference,
        description: Any,
        joints: np.ndarray,
        *,
        theta: np.ndarray,
        runtime: Runtime,
    ) -> tuple[ReferenceRecords, np.ndarray]:
        """Its candidate images: at each pose, a record per target the camera would see there (in front of it
        and on its image at its guessed pose); a pose that shows none gives none (`unseen_filter`)."""
        # Imported here: pose design's modules load the convex solvers, which a process that only reads and
        # fits campaigns never needs (as service.services.reports loads matplotlib with its first report).
        from optimal_design.references import camera_candidates  # noqa: PLC0415

        camera = cast(Camera, reference)
        assert description.targets_mm is not None  # `design_reference` refused a camera without them
        targets = np.asarray(description.targets_mm, dtype=float)
        sigma_px = description.sigma_px or DEFAULT_SIGMA_PX
        images = camera_candidates(desc, camera, joints, targets, sigma_px=sigma_px, params=theta, runtime=runtime)
        if images.size == 0:
            raise InvalidInput(
                f"camera {camera.name!r} sees none of its {len(targets)} targets from any of its {joints.shape[0]} "
                "candidate poses (none in front of it and on its image): its pose guess (position_mm, "
                "rotation_vector_deg: where it is and which way it looks, OpenCV's z forward) or its targets_mm "
                f"(mm, in the {'tool' if camera.mount == 'world' else 'world'} frame) are likely wrong",
                field=f"cameras.{camera.name}",
                value=camera.name,
                reason="camera_sees_nothing",
            )
        return images, images.values[:, 0].astype(np.intp)

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        # The unknowns turn the start orientation; the report states the orientation itself.
        turned = matrix_to_rotvec_np(reference.orientation(values[3:6]))
        return {
            "position_mm": [float(v) for v in values[:3]],
            "rotation_vector_deg": [float(v) * Kind.ANGLE.to_boundary for v in turned],
        }

    def group(
        self,
        desc: RobotDescription,
        described: Described,
        name: str,
        records: Sequence[Any],
        index: Sequence[int],
        *,
        sigma_mm: float,
    ) -> ReferenceRecords:
        """One camera's images as its records, one a seen point, each named by its image's place in the campaign
        (an image's σ is in px: `sigma_mm` does not apply)."""
        camera = self.descriptions(described)[name]
        images = [
            {
                "camera": name,
                "joints": q,
                "points": [p.model_dump() for p in r.points],
                **({"sigma_px": r.sigma_px} if r.sigma_px is not None else {}),
            }
            for r, q in zip(records, joints_in(desc, [r.joints for r in records]), strict=True)
        ]
        [group] = read_images({name: camera.model_dump(exclude_none=True)}, images)
        image = group.values[:, 0].astype(int)
        values = group.values.copy()
        values[:, 0] = np.asarray(index)[image]  # messages name the image as the campaign does
        return ReferenceRecords(group.reference, group.joints, values, group.sigma_mm, np.asarray(index)[image])

    def read_row(self, row: FileRow, out: list[dict[str, Any]]) -> None:
        """An image row is one point a camera saw: consecutive rows of one camera at the same joints (and the
        same `image` id, where the file has the column) are one image."""
        table, line = row.table, row.row.line
        missing = [c for c in SEEN_COLUMNS if c not in table.columns]
        if missing:
            raise CampaignFileError(
                f"line {line}: an image row needs the columns x, y, z (the point) and u, v (its pixel); missing: "
                f"{listed(missing)}",
                line=line,
            )
        scale = length_factor(table, "x", row.options)
        point = {
            "target_mm": [table.number(row.row, c) * scale for c in ("x", "y", "z")],
            "pixel": [table.number(row.row, c) for c in ("u", "v")],
        }
        image_id = row.row.cells.get(IMAGE_COLUMN, "").strip()
        last = out[-1] if out else None
        if (
            last is not None
            and _GROUPING in last
            and last["camera"] == row.name
            and last["joints"] == row.joints
            and last[_GROUPING] == image_id
        ):
            last["points"].append(point)
            return
        rec: dict[str, Any] = {
            "kind": self.name,
            "joints": row.joints,
            "camera": row.name,
            "points": [point],
            _GROUPING: image_id,
        }
        if "sigma_px" in table.columns and row.row.cells.get("sigma_px", "").strip():
            rec["sigma_px"] = table.number(row.row, "sigma_px")
        out.append(rec)

    def file_rows(self, record: Any) -> list[dict[str, str]]:
        sigma_px = cell(record.sigma_px)
        return [
            {
                "kind": self.file_kinds[0],
                "reference": record.camera,
                **{c: cell(v) for c, v in zip(SEEN_COLUMNS, (*p.target_mm, *p.pixel), strict=True)},
                "sigma_px": sigma_px,
            }
            for p in record.points
        ]

    def finish(self, record: dict[str, Any]) -> None:
        record.pop(_GROUPING, None)


IMAGE = ImageKind()
