"""Validations (api.md, validations) and the ISO 9283 cube poses. Boundary units: mm, degrees."""

from __future__ import annotations

from datetime import datetime

from pydantic import Field

from service.record_kinds import CampaignRecord, ReferenceDescriptions
from service.schemas.calibrations import (
    MAX_MEASUREMENTS,
    Instrument,
    InstrumentPublic,
)
from service.schemas.common import (
    STRICT_BY_ALIAS,
    FreeText,
    ImportNotes,
    ImportNotesPublic,
    Measurement,
    Public,
    Strict,
    absent_if_none,
)

MAX_VERSIONS = 50


class ValidationCreate(ReferenceDescriptions):
    """Records of any kind: a tracker's are compared with each version's forward kinematics; distance, point
    and plane records with the version after their anchors, points and planes are placed where the records put
    them (`registered` is then true: the references' unknowns are fitted, the robot is not)."""

    model_config = STRICT_BY_ALIAS
    measurements: list[CampaignRecord] = Field(min_length=1, max_length=MAX_MEASUREMENTS)
    versions: list[int] | None = Field(
        default=None,
        min_length=1,
        max_length=MAX_VERSIONS,
        description="Parameter versions to evaluate (default: the current one)",
    )
    fit_frame: bool = Field(
        default=False,
        alias="register",
        description="Fit the instrument frame to each version first (best rigid motion, closed form): for the "
        "nominal version, or a version calibrated from another station. The errors then show the geometry alone",
    )
    notes: FreeText | None = None
    instrument: Instrument | None = None
    import_notes: ImportNotes


class PercentilesPublic(Public):
    p50: float
    p90: float
    p95: float
    p99: float


class PositionStatsPublic(Public):
    rms: float
    max: float
    percentiles: PercentilesPublic


class OrientationStatsPublic(Public):
    rms: float
    max: float


class PoseErrorPublic(Public):
    position_mm: float
    orientation_deg: float | None = absent_if_none()


class IsoPosePublic(Public):
    """ISO 9283 §7.2 for one commanded pose over its cycles."""

    joints: list[float] = Field(description="The repeated joint command")
    cycles: int
    records: list[int] = Field(description="Indices of its records in the campaign")
    commanded_mm: list[float] = Field(description="The version's FK of the command")
    barycentre_mm: list[float]
    AP_mm: float = Field(description="Distance of the barycentre of the attained positions from the command")
    AP_xyz_mm: list[float] = Field(description="Barycentre − command, per axis")
    RP_mm: float = Field(description="Mean distance to the barycentre + 3 × its sample standard deviation")
    AP_abc_deg: list[float] | None = absent_if_none("Orientation accuracy about a, b, c")
    RP_abc_deg: list[float] | None = absent_if_none("Orientation repeatability ±3 S about a, b, c")


class IsoDistancePublic(Public):
    """ISO 9283 §7.3 between two consecutive repeated poses with as many cycles."""

    poses: list[int] = Field(description="Indices into iso9283.poses")
    cycles: int
    commanded_mm: float
    mean_attained_mm: float
    AD_mm: float = Field(description="Mean attained distance − commanded distance")
    RD_mm: float = Field(description="3 × the sample standard deviation of the attained distances")


class Iso9283Public(Public):
    poses: list[IsoPosePublic]
    distances: list[IsoDistancePublic]


class VersionResultPublic(Public):
    version: int
    registered: bool
    position_mm: PositionStatsPublic
    orientation_deg: OrientationStatsPublic | None = absent_if_none()
    per_pose: list[PoseErrorPublic]
    iso9283: Iso9283Public | None = absent_if_none("When the campaign repeats joint commands")


class ValidationPublic(Public):
    id: str
    robot_id: str
    campaign_id: str
    created_at: datetime
    measurement: Measurement
    measurements: int
    notes: str | None
    instrument: InstrumentPublic | None
    results: list[VersionResultPublic]
    import_notes: ImportNotesPublic


class IsoPosesCreate(Strict):
    version: int | None = Field(default=None, ge=1, le=2**31 - 1, description="Default: the current version")
    seed: int = Field(default=9283, ge=0, le=2**31 - 1, description="Of the workspace sample the cube is sized on")


class NamedPointPublic(Public):
    name: str
    position: list[float] = Field(description="mm, in the version's frame")


class IsoCommandPublic(NamedPointPublic):
    joints: list[float] = Field(description="The command that puts the version's TCP there")


class IsoPosesPublic(Public):
    robot_id: str
    version: int
    edge_mm: float
    centre_mm: list[float]
    orientation: list[float] = Field(description="The one TCP orientation of P1…P5 [w, x, y, z]")
    corners: list[NamedPointPublic] = Field(description="C1…C8")
    poses: list[IsoCommandPublic] = Field(description="P1 (centre) … P5")
