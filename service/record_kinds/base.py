"""What a record kind is (`RecordKind`): one object per instrument's record that the service's tables are derived
from, so the code that composes a campaign of several kinds looks its records' kind up instead of asking which
one it holds (the registry: `service.record_kinds`)."""

from __future__ import annotations

import math
import operator
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import reduce
from types import UnionType
from typing import Annotated, Any, ClassVar, NamedTuple, Union, get_args, get_origin

import numpy as np
from pydantic import BaseModel, Field, create_model

from models import RobotDescription
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.measurement import MeasurementKind
from models.measurements.references import AnyReference, ReferenceRecords
from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.records import ImportOptions, length_factor
from service.campaign_io.tabular import Row, Table
from service.conversions.kinematics import joints_in
from service.errors import BadRequest
from service.schemas.common import Public

ModelReference = AnyReference
"""What a group of records measures in the models (`ReferenceRecords.reference`)."""
Vector = tuple[float, float, float]
"""A reference's guessed position or direction, as its description gives it (mm)."""
SIGMA_COLUMNS = ("sigma_mm", "sigma", "uncertainty")
"""Where a file gives a record's σ in mm (the first present is read)."""
POSITION_COLUMNS = ("x", "y", "z")
"""A tracker reading's columns in the layout of several kinds."""


@dataclass(frozen=True)
class Described:
    """The references a body describes: each kind's map (`RecordKind.described_in`: its `anchors`, `points`, …)
    by its name (`service.record_kinds.described` reads them off a body)."""

    maps: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def of_kind(self, plural: str) -> Mapping[str, Any]:
        """The references described in the map `plural` (none where the body has no such map)."""
        return self.maps.get(plural, {})


@dataclass(frozen=True)
class FileRow:
    """One row of a campaign file in the layout of several kinds, as a kind reads it."""

    table: Table
    row: Row
    joints: list[float]
    name: str
    """The reference column's cell, stripped ("" where the file has none)."""
    options: ImportOptions

    def position_mm(self, what: str) -> list[float]:
        """The row's x, y, z in mm (a tracker's reading of a reflector); a `CampaignFileError` naming the missing
        columns and `what` needs them otherwise."""
        missing = [c for c in POSITION_COLUMNS if c not in self.table.columns]
        if missing:
            raise CampaignFileError(
                f"line {self.row.line}: {what} needs the columns x, y, z (missing: {listed(missing)})",
                line=self.row.line,
            )
        scale = length_factor(self.table, "x", self.options)
        return [self.table.number(self.row, c) * scale for c in POSITION_COLUMNS]

    def sigma_mm(self, record: dict[str, Any]) -> None:
        """The row's σ (mm) onto `record`, where the file gives one."""
        sigma = first_column(self.table, SIGMA_COLUMNS)
        if sigma and self.row.cells.get(sigma, "").strip():
            record["sigma_mm"] = self.table.number(self.row, sigma) * length_factor(self.table, sigma, self.options)


def first_column(table: Table, names: Sequence[str]) -> str | None:
    return next((n for n in names if n in table.columns), None)


def cell(value: float | None) -> str:
    """A number as the campaign CSV writes it: exactly as stored (repr), empty for none."""
    return "" if value is None else repr(float(value))


def described_map(max_length: int, description: str) -> Any:
    """The `Field` of a body's map of a kind's references (`RecordKind.described_field`): none by default, at most
    `max_length`, `description` in the contract."""
    return Field(default_factory=dict, max_length=max_length, description=description)


def public_form(record: type[BaseModel]) -> type[BaseModel]:
    """The public schema of a kind whose stored record is its request as taken (`RecordKind.public`): the
    request's fields in its order, their types without the bounds, descriptions and examples (what the service
    gives back, it took validated), named as the request's schema with `Public` after it."""
    fields: dict[str, Any] = {
        name: (_unbounded(info.annotation), ... if info.is_required() else info.default)
        for name, info in record.model_fields.items()
    }
    return create_model(f"{record.__name__}Public", __base__=Public, __module__=record.__module__, **fields)


def _unbounded(annotation: Any) -> Any:
    """A field's type without its `Annotated` bounds at any depth: `list[Annotated[float, …]] | None` is
    `list[float] | None` (a `Literal`, a plain type as it is)."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _unbounded(args[0])
    if origin is list:
        return list[_unbounded(args[0])]  # type: ignore[misc]  # a type built at run time
    if origin in (Union, UnionType):
        return reduce(operator.or_, map(_unbounded, args))
    return annotation


class Reading(ABC):
    """What a kind's records measured, one field of each (`field`): how a file's row gives it, the cells the layout
    of several kinds writes it in, and the numbers the models fit."""

    field: str

    @property
    @abstractmethod
    def written(self) -> tuple[str, ...]:
        """The columns of the layout of several kinds its `cells` fill."""

    @abstractmethod
    def read(self, row: FileRow, what: str) -> Any:
        """The row's reading (mm); a `CampaignFileError` naming `what` where the file cannot give it."""

    @abstractmethod
    def cells(self, value: Any) -> dict[str, str]:
        """A record's reading as cells of the layout of several kinds, by column."""

    def notes(self, table: Table, options: ImportOptions) -> list[str]:
        """What reading a file's columns for it says (a unit converted)."""
        return []


class PositionReading(Reading):
    """A point's position, x, y, z in mm in the instrument's frame (a tracker's reading of a reflector)."""

    field = "position"

    @property
    def written(self) -> tuple[str, ...]:
        return POSITION_COLUMNS

    def read(self, row: FileRow, what: str) -> list[float]:
        return row.position_mm(what)

    def cells(self, value: Any) -> dict[str, str]:
        return {c: cell(v) for c, v in zip(self.written, value, strict=True)}


@dataclass(frozen=True)
class LengthReading(Reading):
    """One length in mm (a distance, a displacement) in `field`; a file gives it in the first of `columns` present,
    a unit in its header converted (the notes name it `plural`)."""

    field: str
    columns: tuple[str, ...]
    plural: str

    @property
    def written(self) -> tuple[str, ...]:
        return (self.field,)

    def read(self, row: FileRow, what: str) -> float:
        column = first_column(row.table, self.columns)
        if column is None:
            raise CampaignFileError(f"line {row.row.line}: {what} needs a {self.field} column", line=row.row.line)
        return row.table.number(row.row, column) * length_factor(row.table, column, row.options)

    def cells(self, value: Any) -> dict[str, str]:
        return {self.field: cell(value)}

    def notes(self, table: Table, options: ImportOptions) -> list[str]:
        column = first_column(table, self.columns)
        scale = length_factor(table, column, options) if column else 1.0
        return [f"{self.plural} converted to mm (×{scale:g})"] if scale != 1.0 else []


POSITION = PositionReading()
"""The reading of a tracker's records and of a second reflector's: where the instrument saw the target."""


class MustDescribe(NamedTuple):
    """What the 400 says where a record measures a reference the body must describe and does not
    (`RecordKind.must_describe`)."""

    measures: str
    """How a record measures one ("measures anchor")."""
    least: str
    """The least description that will do, as the body gives it ("{}")."""
    why: str
    """What the message adds after it, in brackets."""


class RecordKind(ABC):
    """A kind of campaign record: its schemas, its file rows and how its records become the model's inputs."""

    name: ClassVar[str]
    """Its tag in the API (`kind`; a tracker's records carry none, their tag is "tracker")."""
    model: ClassVar[str]
    """The kind of the models' reference its records measure (`Traits.kind` in `models.measurements`)."""
    measurement_kinds: ClassVar[tuple[MeasurementKind, ...]] = ()
    """The models' `MeasurementKind`s its records are, where a whole campaign of them is one (a tracker's)."""
    record: ClassVar[type[BaseModel]]
    """Its request schema (a member of the campaign record union)."""
    public: ClassVar[type[BaseModel]]
    """Its stored, public schema (a member of `CampaignPublic.measurements`): `public_form(record)` where the stored
    record is the request as taken."""
    named_by: ClassVar[str | None] = None
    """The record's field that names the reference it measures; none where it measures no named reference."""
    description: ClassVar[type[BaseModel] | None] = None
    """The schema of one of its references' descriptions (the values of that map)."""
    described_field: ClassVar[Any] = None
    """The map's `Field` (its description in the contract, its size bound)."""
    must_describe: ClassVar[MustDescribe | None] = None
    """Whether the body must describe every reference its records measure (`check_described`), and how the 400
    says it; None: a description is an optional guess."""
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {}
    """The fields of `ReferencePublic` its identified references fill of their own beside `position_mm`
    (`reported`), each (annotation, `Field`)."""
    example_name: ClassVar[str] = ""
    """A name its reference takes in the messages' examples ("a1")."""
    design_description: ClassVar[str] = "{}"
    """What a pose design needs described of its reference, as a message shows it."""
    sampled: ClassVar[bool] = False
    """Whether a sampled pose can be one of its records (a ballbar reads wherever its range allows, a camera sees
    wherever its targets come into view; no sampled pose puts the TCP on a point or a plane)."""
    more_candidates: ClassVar[str] = "raise candidate_count"
    """How a sampled design gets more of its records."""
    readable_filter: ClassVar[str | None] = None
    """The name of the filter its `readable` applies to a sampled design's poses, as the report counts what it
    excluded ("range_mm": where its instrument reads); None: it filters none."""
    unseen_filter: ClassVar[str | None] = None
    """The name under which a design counts the candidate poses that give none of its records ("not_seen": a
    camera that would see none of its targets there); None: every pose gives its record."""
    timed: ClassVar[bool] = False
    """Whether its records say when they were measured (`time`): a campaign of them alone has a timeline (the
    instrument's drift fitted over it, the span the report's conditions state)."""
    reading: ClassVar[Reading | None] = None
    """What each record measured (a position, a length), from which its file rows, its cells and the values the
    models fit follow; None: it measured nothing (a touch), or the kind reads and writes its own (an image)."""

    @property
    def label(self) -> str:
        """How messages name what it measures: by default the field that names its reference ("anchor"), or its
        tag where its records name none ("tracker")."""
        return self.named_by or self.name

    @property
    def described_in(self) -> str | None:
        """The body's map that describes the references it measures, its naming field's plural ("anchors", …;
        `Described`): a field of `ReferenceDescriptions`, which the calibration, check, validation and pose-design
        bodies share. None where its records name no reference."""
        return None if self.named_by is None else f"{self.named_by}s"

    @property
    def file_kinds(self) -> tuple[str, ...]:
        """Its values of a file's `kind` column, lower case; the first is the one written. By default its tag."""
        return (self.name,)

    @property
    def file_columns(self) -> tuple[str, ...]:
        """The columns of the layout of several kinds it fills beside `kind`, `reference` and the joints. By
        default what `file_rows` writes: its `reading`'s and its σ."""
        return (*(() if self.reading is None else self.reading.written), "sigma_mm")

    @property
    def whole_campaign(self) -> bool:
        """Whether a campaign of only its records is one campaign of the models (`measurement_kinds`): the
        capability the operations' pipelines take their specialised path by (`service.services.pipelines`)."""
        return bool(self.measurement_kinds)

    @property
    def designable(self) -> bool:
        """Whether a pose design plans its records (a whole campaign's, or a described reference's)."""
        return self.whole_campaign or self.measures_reference

    @property
    def measures_reference(self) -> bool:
        """Whether its records measure a reference the cell owns (described beside the records)."""
        return self.named_by is not None

    @property
    def tagged(self) -> bool:
        """Whether its records carry their `kind` (a tracker's name none: the contract's rule, `record_tag`)."""
        return "kind" in self.record.model_fields

    def reference_name(self, record: Any) -> str:
        """The name of the reference a record measures (its kind's where it names none)."""
        if self.named_by is None:
            return self.name
        # a record read from a file or stored is a dict; a request's or a public one, a schema
        return str(record[self.named_by] if isinstance(record, Mapping) else getattr(record, self.named_by))

    def descriptions(self, described: Described) -> Mapping[str, Any]:
        """The references of this kind the body describes."""
        return {} if self.described_in is None else described.of_kind(self.described_in)

    def guess(self, described: Described, name: str, key: str, default: Vector = (0.0, 0.0, 0.0)) -> Vector:
        """The description's guess `key` of the reference `name` (where it is, which way it points), `default`
        where the body describes none: the fit starts from the records."""
        x, y, z = getattr(self.descriptions(described).get(name), key, None) or default
        return x, y, z

    def direction_guess(self, described: Described, name: str, key: str, default: Vector, *, give: str) -> Vector:
        """The guess `key` of a direction (a plane's normal, a beam's); a 400 saying to `give` one where the
        description's is the zero vector (it has no direction)."""
        direction = self.guess(described, name, key, default)
        if math.hypot(*direction) == 0.0:
            raise BadRequest(f"{self.label} {name!r}: its {key} is the zero vector; give {give}")
        return direction

    def design_reference(self, name: str, description: Any) -> ModelReference:
        """The reference a pose design plans its records against, from its description (where it stands, a
        plane's normal, a camera's pose); a 422 naming what the design lacks (`lacking`)."""
        raise NotImplementedError(f"{self.name} records measure no described reference")  # pragma: no cover

    def lacking(self, name: str, key: str, what: str, example: str) -> InvalidInput:
        """A described reference without what a design needs of it, and where to give it."""
        plural = self.described_in
        return InvalidInput(
            f'{self.named_by} {name!r}: a design needs {what}: give "{plural}": {{"{name}": {{"{key}": {example}}}}}',
            field=f"{plural}.{name}.{key}",
            value=name,
        )

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        """What the report states of an identified reference of this kind beside its unknowns (boundary units),
        from its fitted unknowns `values` (internal units)."""
        return {}

    def readable(self, reference: ModelReference, description: Any, tcp: np.ndarray) -> np.ndarray | None:
        """Which sampled poses (their nominal TCP positions, mm) its instrument can read there, where its
        description limits them (`readable_filter`); None: every one."""
        return None

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
        """Its candidate records at the poses `joints` (internal units) and each record's pose among them: one
        per pose, measured values zero in the shape its records take (what a record would read does not enter
        its rows); a camera's one per target it would see (`unseen_filter`)."""
        columns = reference.traits.value_columns
        n = joints.shape[0]
        values = np.zeros(n) if columns <= 1 else np.zeros((n, columns))
        return ReferenceRecords(reference, joints, values), np.arange(n, dtype=np.intp)

    def design_has(self, have: int) -> str:
        """A design's count of its candidate records, in its words (a camera's records are points seen)."""
        return f"has {have} admissible candidates"

    def check_described(self, described: Described, name: str, record: int) -> None:
        """A 400 where the body must describe the reference `name` that record `record` measures
        (`must_describe`) and does not."""
        if self.must_describe is None or name in self.descriptions(described):
            return
        measures, least, why = self.must_describe
        raise BadRequest(
            f"record {record} {measures} {name!r}, which the campaign does not describe: add "
            f'"{self.described_in}": {{"{name}": {least}}} ({why})',
            record=record,
        )

    def public_of(self, stored: Mapping[str, Any]) -> dict[str, Any]:
        """A stored record in its public form: the public schema's fields, as stored."""
        return {key: stored.get(key) for key in self.public.model_fields}

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
        """The records of one reference as the models' group (internal units), each keeping its place `index` in
        the campaign (`sigma_mm`: a record's σ where it states none)."""
        joints = joints_in(desc, [r.joints for r in records])
        given = [r.sigma_mm for r in records]
        sigma = None if all(g is None for g in given) else np.array([sigma_mm if g is None else g for g in given])
        reference = self.reference(described, name)
        return ReferenceRecords(reference, joints, self.values(records), sigma, np.asarray(index, dtype=np.intp))

    def reference(self, described: Described, name: str) -> ModelReference:
        """The reference with its description's guesses (the fit computes its start from the records)."""
        raise NotImplementedError(f"{self.name} records build their own groups")  # pragma: no cover

    def values(self, records: Sequence[Any]) -> np.ndarray:
        """What each record measured (internal units, its `reading`): nothing for a touch."""
        if self.reading is None:
            return np.zeros(len(records))
        return np.array([getattr(r, self.reading.field) for r in records], dtype=float)

    def notes(self, records: Sequence[Any]) -> list[str]:
        """What the conversion of these records beside other kinds says."""
        return []

    def table_notes(self, table: Table, options: ImportOptions) -> list[str]:
        """What reading a file's columns for this kind says (a unit converted)."""
        return [] if self.reading is None else self.reading.notes(table, options)

    def read_row(self, row: FileRow, out: list[dict[str, Any]]) -> None:
        """A file row's record (the API's form) appended to `out`, or merged into the last one (an image's
        points); a row it cannot read: a `CampaignFileError` naming its line. By default its tag, its joints, the
        reference it names, its `reading` and its σ."""
        rec: dict[str, Any] = {"kind": self.name} if self.tagged else {}
        rec["joints"] = row.joints
        if self.named_by is not None:
            rec[self.named_by] = row.name
        if self.reading is not None:
            rec[self.reading.field] = self.reading.read(row, f"a {self.name} record")
        row.sigma_mm(rec)
        out.append(rec)

    def finish(self, record: dict[str, Any]) -> None:  # noqa: B027  (optional)
        """A record read from a file, once the whole file is read: the keys only reading needed dropped."""

    def measured_position(self, stored: Mapping[str, Any]) -> list[float] | None:
        """The TCP's position a stored record measured (mm, the instrument's frame), where it measured one: what
        a report draws. None for a distance, a touch, an image."""
        return None

    def write_alone(self, records: Sequence[Any], joint_names: Sequence[str]) -> list[list[str]] | None:
        """A campaign of only its records in a file layout of its own (header first), where it has one that a
        calibration reads back (a tracker's); None: the layout of several kinds (`file_rows`)."""
        return None

    def file_rows(self, record: Any) -> list[dict[str, str]]:
        """A public record as rows of the layout of several kinds, each its cells by column (joints aside). By
        default one row: its kind, the reference it names, its `reading` and its σ."""
        row = {"kind": self.file_kinds[0]}
        if self.named_by is not None:
            row["reference"] = self.reference_name(record)
        if self.reading is not None:
            row.update(self.reading.cells(getattr(record, self.reading.field)))
        row["sigma_mm"] = cell(record.sigma_mm)
        return [row]
