"""The record kinds, one registry entry each: the tables the service reads and writes a campaign's records by
(their schemas, their file columns, how they become the models' inputs, their public form) are derived from
`RECORD_KINDS`, so the code that composes a campaign of several kinds looks a record's kind up (`kind_of`) and
calls it instead of asking which one it holds.

A new record kind is a module here (a `RecordKind` with its request and public schemas; its models' reference in
`models.measurements`) and its entry in `RECORD_KINDS`: the campaign record unions (`CampaignRecord`,
`PublicRecord`), the tags a problem's location may carry, the kinds a pose design may plan are derived from it.
tests/service/test_record_kinds_registry.py checks that they agree with each other, with the models'
`MeasurementKind` and with the OpenAPI document.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from types import MappingProxyType
from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import Discriminator, Tag, create_model

from service.record_kinds.base import SIGMA_COLUMNS, Described, FileRow, RecordKind
from service.record_kinds.displacement import DISPLACEMENT
from service.record_kinds.distance import DISTANCE
from service.record_kinds.image import IMAGE
from service.record_kinds.plane import PLANE
from service.record_kinds.point import POINT
from service.record_kinds.reflector import REFLECTOR
from service.record_kinds.tracker import TRACKER, Record
from service.schemas.references import (
    CandidateBase,
    DescriptionsBase,
    ReferenceName,
    ReferencePublicBase,
    record_tag,
)

RECORD_KINDS: Mapping[str, RecordKind] = MappingProxyType(
    {kind.name: kind for kind in (TRACKER, DISTANCE, POINT, PLANE, IMAGE, REFLECTOR, DISPLACEMENT)}
)
"""Each record kind by its tag (a record's `kind`; a tracker's records name none: "tracker")."""

BY_FILE_KIND: Mapping[str, RecordKind] = MappingProxyType(
    {value: kind for kind in RECORD_KINDS.values() for value in kind.file_kinds}
)
"""Each kind by the values of a file's `kind` column that mean it."""

BY_REFERENCE: Mapping[str, RecordKind] = MappingProxyType(
    {kind.named_by: kind for kind in RECORD_KINDS.values() if kind.named_by is not None}
)
"""Each kind that measures a named reference by the field that names it: a design's candidate names "anchor",
"point", "plane" or "camera"."""

BY_MODEL: Mapping[str, RecordKind] = MappingProxyType({kind.model: kind for kind in RECORD_KINDS.values()})
"""Each kind by the models' name of the reference its records measure (`Traits.kind`: an identified reference's)."""

REFERENCE_KINDS: tuple[str, ...] = tuple(name for name, kind in RECORD_KINDS.items() if kind.measures_reference)
"""The kinds whose records measure a reference the cell owns: what a pose design may plan beside a tracker's."""

BY_MEASUREMENT: Mapping[str, RecordKind] = MappingProxyType(
    {
        **{m.value: kind for kind in RECORD_KINDS.values() for m in kind.measurement_kinds},
        **{name: RECORD_KINDS[name] for name in REFERENCE_KINDS},
    }
)
"""The kind whose records a pose design's `measurement` plans: a tracker's for pose and position, each reference
kind by its own name."""

RECORD_KIND_ERROR = {
    "custom_error_type": "record_kind",
    "custom_error_message": "a record's kind is one of "
    + ", ".join(repr(name) for name in REFERENCE_KINDS)
    + ", or absent (a tracker's)",
}

if TYPE_CHECKING:
    CampaignRecord = Any
    PublicRecord = Any
else:
    # Built from the registry, in its order (the OpenAPI document's): a record's schema is its kind's.
    CampaignRecord = Annotated[
        Union[tuple(Annotated[kind.record, Tag(name)] for name, kind in RECORD_KINDS.items())],  # noqa: UP007
        Discriminator(record_tag, **RECORD_KIND_ERROR),
    ]
    PublicRecord = Union[tuple(kind.public for kind in RECORD_KINDS.values())]  # noqa: UP007
"""A campaign's record as a request carries it (a tracker's names no `kind`), and as the service gives it back."""

DESCRIBING: tuple[RecordKind, ...] = tuple(kind for kind in RECORD_KINDS.values() if kind.described_in is not None)
"""The kinds whose references a body describes, each in a map of its own (`RecordKind.described_in`)."""
REPORTED: tuple[str, ...] = (
    *(kind.model for kind in RECORD_KINDS.values() if kind.measures_reference),
    TRACKER.model,
)
# The contract published the tracker's positions after the first three references (anchor, point, plane) and
# appended the later ones after it: the order is the registry's with the tracker's moved there.
REPORTED = (*REPORTED[:3], REPORTED[-1], *REPORTED[3:-1])
"""The models' kinds of reference a calibration's report names (`ReferencePublic.kind`)."""

CANDIDATE_DOC = (
    "A candidate pose of a pose design, tied to the reference its record would measure (name one): a camera's\n"
    "    is the image it would take there."
)
"""Its description in the contract, as published (with its line break)."""

if TYPE_CHECKING:
    ReferenceDescriptions = DescriptionsBase
    ReferenceCandidate = CandidateBase
    ReferencePublic = ReferencePublicBase
else:
    ReferenceDescriptions = create_model(
        "ReferenceDescriptions",
        __base__=DescriptionsBase,
        __module__=__name__,
        __doc__="""The references a campaign's records measure, or a pose design's records would, described (a base
    of the bodies that carry records, and of the pose design's).""",
        **{
            kind.described_in: (dict[ReferenceName, kind.description], kind.described_field)  # type: ignore[valid-type]
            for kind in DESCRIBING
        },
    )
    ReferenceCandidate = create_model(
        "ReferenceCandidate",
        __base__=CandidateBase,
        __module__=__name__,
        __doc__=CANDIDATE_DOC,
        **dict.fromkeys(BY_REFERENCE, (ReferenceName | None, None)),
    )
    ReferencePublic = create_model(
        "ReferencePublic",
        __base__=ReferencePublicBase,
        __module__=__name__,
        __doc__="A reference as the calibration identified it, in the frame the report's `frame` names.",
        kind=(Literal[REPORTED], ...),
        **{name: spec for kind in RECORD_KINDS.values() for name, spec in kind.report_fields.items()},
    )
"""The tables of the bodies that describe references, of a design's candidates and of the report's references:
one map, one naming field and each kind's report fields per kind, from the registry."""


def described(body: Any) -> Described:
    """What a request body describes (a calibration's, a check's, a validation's, a pose design's)."""
    return Described({str(kind.described_in): getattr(body, str(kind.described_in)) for kind in DESCRIBING})


KIND_COLUMN = "kind"
REFERENCE_COLUMNS = ("reference", "anchor", "plane", "feature", "camera")
"""Where a file names the reference a row measures (the first present is read)."""
WRITTEN_COLUMNS = ("distance_mm", "x", "y", "z", "u", "v", "sigma_mm", "sigma_px")
"""The kinds' columns in the order the files have had them (a later kind's new columns follow)."""
FILE_COLUMNS = (
    KIND_COLUMN,
    "reference",
    *WRITTEN_COLUMNS,
    *dict.fromkeys(c for kind in RECORD_KINDS.values() for c in kind.file_columns if c not in WRITTEN_COLUMNS),
)
"""The layout of several kinds as the service writes it, the joints after `reference`: the union of the kinds'
`file_columns` (tests/service/test_record_kinds_registry.py checks it)."""


def kind_of(record: Any) -> RecordKind:
    """The kind of a record: a request's or a public schema's, or a stored or read record (a dict)."""
    return RECORD_KINDS[record_tag(record)]


def sole_kind(measurements: Iterable[Any]) -> RecordKind | None:
    """The one kind of every record of a campaign; None where it holds several (or none). What a pipeline asks
    before it takes a specialised path for a campaign of one kind (by that kind's capabilities, never its name:
    `RecordKind.measurement_kinds`, `RecordKind.write_alone`)."""
    kinds = {kind_of(r) for r in measurements}
    return kinds.pop() if len(kinds) == 1 else None


def file_kinds_listed() -> str:
    """The kinds a file's `kind` column may name, for messages."""
    return ", ".join(RECORD_KINDS)


def public_records(stored: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Stored records in their public form."""
    return [kind_of(r).public_of(r) for r in stored]


__all__ = [
    "BY_FILE_KIND",
    "BY_MEASUREMENT",
    "BY_MODEL",
    "BY_REFERENCE",
    "DESCRIBING",
    "DISPLACEMENT",
    "DISTANCE",
    "FILE_COLUMNS",
    "IMAGE",
    "KIND_COLUMN",
    "PLANE",
    "POINT",
    "RECORD_KINDS",
    "RECORD_KIND_ERROR",
    "REFERENCE_COLUMNS",
    "REFERENCE_KINDS",
    "REFLECTOR",
    "REPORTED",
    "SIGMA_COLUMNS",
    "TRACKER",
    "CampaignRecord",
    "Described",
    "FileRow",
    "PublicRecord",
    "Record",
    "RecordKind",
    "ReferenceCandidate",
    "ReferenceDescriptions",
    "ReferencePublic",
    "described",
    "file_kinds_listed",
    "kind_of",
    "public_records",
    "sole_kind",
]
