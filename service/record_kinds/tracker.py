"""A laser tracker's record: the TCP's position (and, with a 6-DOF probe, its orientation) in the instrument's
frame. A campaign of them alone is the models' pose or position campaign; beside other kinds, their positions
fix the frame."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

from pydantic import Field

from models.measurement import MeasurementKind
from models.measurements.references import TrackerPositions
from service.record_kinds.base import POSITION, POSITION_COLUMNS, Described, ModelReference, Reading, RecordKind
from service.schemas.common import JointVector, Payload, Position, Public, Quaternion, RecordTime, Strict, TemperatureC

ORIENTATION_COLUMNS = ("qw", "qx", "qy", "qz")
"""A tracker file's orientation columns (a unit quaternion), after x, y, z."""


class Record(Strict):
    joints: JointVector
    position: Position
    orientation: Quaternion | None = None
    sigma_mm: float | None = Field(
        default=None,
        gt=0,
        le=100,
        description="This record's position uncertainty (1 σ, mm; a tracker's U95 / 2); default: noise.position_mm",
    )
    temperature_c: TemperatureC | None = Field(
        default=None, description="The robot's temperature at this record (°C); required by the thermal term"
    )
    payload: Payload | None = Field(default=None, description="This record's payload (default: the campaign's)")
    time: RecordTime | None = Field(
        default=None,
        description="When the record was measured: seconds from any origin, or an ISO 8601 time (without an offset: "
        "UTC); a drift-aware calibration fits the instrument's drift over it (default: the record order)",
    )
    reference: bool = Field(
        default=False,
        description="This record measures the campaign's reference pose, the one pose measured again every few "
        "records of a drift-aware calibration (options.drift); none marked: the pose measured most often",
    )


class CampaignRecordPublic(Public):
    joints: list[float] = Field(description="[q1 (mm), q2 (mm), q3 (deg), q4 (deg), l1 … l6 (mm)]")
    position: list[float] = Field(description="mm")
    orientation: list[float] | None = Field(description="unit quaternion [w, x, y, z]; null when not measured")
    sigma_mm: float | None = Field(
        default=None, description="The record's own position σ (mm; a file's U(95) / 2); null: the campaign's noise"
    )
    temperature_c: float | None = Field(default=None, description="The record's temperature (°C); null: none given")


class TrackerKind(RecordKind):
    name: ClassVar[str] = "tracker"
    model: ClassVar[str] = TrackerPositions.traits.kind
    measurement_kinds: ClassVar[tuple[MeasurementKind, ...]] = (MeasurementKind.POSE, MeasurementKind.POSITION)
    record = Record
    public = CampaignRecordPublic
    file_kinds: ClassVar[tuple[str, ...]] = ("tracker", "", "position")
    timed: ClassVar[bool] = True
    sampled: ClassVar[bool] = True  # a tracker reads wherever it sees the reflector
    # The layout of several kinds carries a tracker record's position and σ; its orientation and temperature only
    # the tracker layout does (a campaign of tracker records alone is written in it: `write_alone`).
    reading: ClassVar[Reading | None] = POSITION

    def measured_position(self, stored: Mapping[str, Any]) -> list[float] | None:
        return [float(v) for v in stored["position"]]

    def write_alone(self, records: Sequence[Any], joint_names: Sequence[str]) -> list[list[str]] | None:
        """The tracker layout (what POST …/calibrations reads): the joints, x, y, z and, where any record has one,
        the orientation's quaternion; numbers exactly as stored."""
        with_orientation = any(r.orientation is not None for r in records)
        # A record's own σ and temperature (a tracker file's U(95) / 2, its Temperature column) go back out with
        # it, so the CSV fitted again is the same campaign.
        extra = [c for c in ("sigma_mm", "temperature_c") if any(getattr(r, c) is not None for r in records)]
        pose = (*POSITION_COLUMNS, *ORIENTATION_COLUMNS) if with_orientation else POSITION_COLUMNS
        rows = [[*joint_names, *pose, *extra]]
        for r in records:
            cells = [repr(float(v)) for v in (*r.joints, *r.position)]
            if with_orientation:
                cells += [repr(float(v)) for v in r.orientation] if r.orientation is not None else ["", "", "", ""]
            cells += ["" if (v := getattr(r, c)) is None else repr(float(v)) for c in extra]
            rows.append(cells)
        return rows

    def reference(self, described: Described, name: str) -> ModelReference:
        return TrackerPositions()

    def notes(self, records: Sequence[Any]) -> list[str]:
        if any(r.orientation is not None for r in records):
            return [
                "the tracker records' orientations are not used beside distance, point or plane records: their "
                "positions fix the frame"
            ]
        return []


TRACKER = TrackerKind()
