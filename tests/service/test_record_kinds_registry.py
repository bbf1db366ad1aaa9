"""The record kinds registry is complete: a campaign record kind is one module in service/record_kinds/ (its
schemas and the models' reference it measures aside), registered once; see docs/architecture.md."""

from __future__ import annotations

import inspect
import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, get_args

import pytest

from models.measurement import MeasurementKind
from models.measurements.camera import Camera, ToolCamera
from models.measurements.line import Line
from models.measurements.references import Anchor, FixedPoint, Plane, Reflector, TrackerPositions
from service.errors import BadRequest
from service.files.csv_codec import JOINT_HEADER, parse_campaign
from service.record_kinds import (
    BY_FILE_KIND,
    FILE_COLUMNS,
    RECORD_KINDS,
    CampaignRecord,
    Described,
    kind_of,
    sole_kind,
)
from service.routes.campaigns import campaign_csv
from service.schemas.campaigns import CampaignPublic

OPENAPI = json.loads((Path(__file__).parents[2] / "service" / "openapi.json").read_text())["components"]["schemas"]
MODEL_REFERENCES = (Anchor, FixedPoint, Plane, TrackerPositions, Reflector, Camera, ToolCamera, Line)
"""Every kind of reference the models group records by (`ReferenceRecords.reference`)."""

JOINTS = [10.0, -20.5, 30.25, 5.0, 1001.5, 1002.25, 1003.0, 1004.0, 1005.5, 1006.0]
SAMPLES: dict[str, list[dict[str, Any]]] = {
    "tracker": [
        {"joints": JOINTS, "position": [812.125, -40.5, 633.0]},
        {"joints": JOINTS, "position": [1.0, 2.0, 3.5], "sigma_mm": 0.0125},
    ],
    "distance": [
        {"kind": "distance", "joints": JOINTS, "anchor": "a1", "distance_mm": 150.0012},
        {"kind": "distance", "joints": JOINTS, "anchor": "a2", "distance_mm": 149.5, "sigma_mm": 0.002},
    ],
    "point": [{"kind": "point", "joints": JOINTS, "point": "p1"}, {"kind": "point", "joints": JOINTS, "point": "p1"}],
    "plane": [{"kind": "plane", "joints": JOINTS, "plane": "f1", "sigma_mm": 0.005}],
    "image": [
        {
            "kind": "image",
            "joints": JOINTS,
            "camera": "c1",
            "points": [
                {"target_mm": [25.0, -25.0, 0.0], "pixel": [1023.41, 611.87]},
                {"target_mm": [-25.0, 25.0, 0.0], "pixel": [900.5, 700.25]},
            ],
            "sigma_px": 0.1,
        },
        # the same camera at the same joints again: a second image only through the layout's `image` column,
        # which the service does not write; a different pose is a different image
        {
            "kind": "image",
            "joints": [*JOINTS[:9], 1007.0],
            "camera": "c1",
            "points": [{"target_mm": [0.0, 0.0, 1.0], "pixel": [1.0, 2.0]}],
        },
    ],
    "reflector": [
        {"kind": "reflector", "joints": JOINTS, "reflector": "r2", "position": [892.0625, -40.5, 613.875]},
        {"kind": "reflector", "joints": JOINTS, "reflector": "r3", "position": [812.5, 29.75, 613.0], "sigma_mm": 0.01},
    ],
    "displacement": [
        {"kind": "displacement", "joints": JOINTS, "line": "l1", "displacement_mm": -120.0625},
        {"kind": "displacement", "joints": JOINTS, "line": "l1", "displacement_mm": 33.5, "sigma_mm": 0.0005},
    ],
}
"""Hand-written records of each kind as the API takes them (numbers chosen to need every digit repr writes)."""


def _union_members(annotation: Any) -> list[tuple[type, str]]:
    """The (schema, tag) pairs of the campaign record union `Annotated[Annotated[S, Tag(t)] | …, Discriminator]`."""
    union, *_ = get_args(annotation)
    out = []
    for member in get_args(union):
        schema, tag = get_args(member)
        out.append((schema, tag.tag))
    return out


def test_every_kind_is_registered_under_its_tag_and_once() -> None:
    assert all(kind.name == tag for tag, kind in RECORD_KINDS.items())
    assert len({id(k) for k in RECORD_KINDS.values()}) == len(RECORD_KINDS)
    values = [v for kind in RECORD_KINDS.values() for v in kind.file_kinds]
    assert len(values) == len(set(values)) == len(BY_FILE_KIND)  # a file's kind value means one kind
    assert all(v == v.strip().lower() for v in values)  # the reader compares them stripped and lower case


def test_every_measurement_kind_is_one_record_kind() -> None:
    claimed = [m for kind in RECORD_KINDS.values() for m in kind.measurement_kinds]
    assert sorted(claimed) == sorted(MeasurementKind)


def test_every_model_reference_is_measured_by_exactly_one_record_kind() -> None:
    models = {cls.traits.kind for cls in MODEL_REFERENCES}
    assert sorted(kind.model for kind in RECORD_KINDS.values()) == sorted(models)


def test_the_campaign_record_union_is_the_registry() -> None:
    members = _union_members(CampaignRecord)
    assert {tag: schema for schema, tag in members} == {k.name: k.record for k in RECORD_KINDS.values()}
    public = get_args(CampaignPublic.model_fields["measurements"].annotation)[0]
    assert set(get_args(public)) == {k.public for k in RECORD_KINDS.values()}


def test_every_record_union_of_the_api_document_is_the_registry() -> None:
    requests = {kind.record.__name__ for kind in RECORD_KINDS.values()}
    publics = {kind.public.__name__ for kind in RECORD_KINDS.values()}
    unions = [
        {ref["$ref"].rsplit("/", 1)[1] for ref in items.get("oneOf", items.get("anyOf", []))}
        for schema in OPENAPI.values()
        if (items := schema.get("properties", {}).get("measurements", {}).get("items", {}))
    ]
    record_unions = [u for u in unions if len(u) > 1]
    assert requests in record_unions and publics in record_unions
    assert all(u in (requests, publics) for u in record_unions), record_unions


@pytest.mark.parametrize("name", list(RECORD_KINDS))
def test_every_kind_is_whole(name: str) -> None:
    kind = RECORD_KINDS[name]
    assert not inspect.isabstract(type(kind)), getattr(type(kind), "__abstractmethods__", None)
    assert kind.label and kind.file_kinds and kind.file_columns
    # the reference it is named by is a field of both its schemas, and a tracker's names none
    assert (kind.named_by is None) == (kind.measurement_kinds != ())
    if kind.named_by is not None:
        assert kind.named_by in kind.record.model_fields and kind.named_by in kind.public.model_fields
    # the public schema shows what the request took (the stored records are the requests')
    assert set(kind.public.model_fields) <= set(kind.record.model_fields)


def test_the_file_layout_is_the_union_of_the_kinds_columns() -> None:
    assert FILE_COLUMNS[:2] == ("kind", "reference")
    used = {c for kind in RECORD_KINDS.values() for c in kind.file_columns}
    assert used == set(FILE_COLUMNS[2:])


def _campaign(records: list[dict[str, Any]]) -> CampaignPublic:
    stored = [kind_of(r).public_of(r) for r in records]
    return CampaignPublic.model_validate(
        {"id": "c", "robot_id": "r", "created_at": datetime(2026, 1, 1, tzinfo=UTC), "measurements": stored}
    )


@pytest.mark.parametrize("name", list(RECORD_KINDS))
def test_every_kinds_file_rows_round_trip(name: str) -> None:
    # beside a distance record, so that the campaign is written in the layout of several kinds
    records = [*SAMPLES[name], *([] if name == "distance" else SAMPLES["distance"][:1])]
    text = campaign_csv(_campaign(records), JOINT_HEADER)
    assert text.splitlines()[0].split(",")[0] == "kind"
    read, notes = parse_campaign(text)
    assert read == records, notes
    assert [kind_of(r) for r in read] == [kind_of(r) for r in records]


def test_every_kind_has_a_sample() -> None:
    assert set(SAMPLES) == set(RECORD_KINDS)
    assert all(kind_of(r) is RECORD_KINDS[name] for name, rs in SAMPLES.items() for r in rs)


def test_a_campaigns_sole_kind_is_the_one_kind_of_all_its_records() -> None:
    records = [r for rs in SAMPLES.values() for r in rs]
    assert sole_kind(records) is None and sole_kind([]) is None
    for name, samples in SAMPLES.items():
        assert sole_kind(samples) is RECORD_KINDS[name]
    # the specialised whole-campaign path is a capability: the kinds that declare the models' campaign kinds
    whole = {name for name, kind in RECORD_KINDS.items() if kind.measurement_kinds}
    assert whole == {name for name, kind in RECORD_KINDS.items() if not kind.measures_reference}


def test_an_undescribed_reference_is_a_4xx_naming_it_where_the_kind_needs_a_description() -> None:
    empty = Described()
    with pytest.raises(BadRequest, match="record 0 measures anchor 'a1', which the campaign does not describe"):
        RECORD_KINDS["distance"].check_described(empty, "a1", 0)
    with pytest.raises(BadRequest, match="record 3 is an image of camera 'c1', which the campaign does not describe"):
        RECORD_KINDS["image"].check_described(empty, "c1", 3)
    for name in ("tracker", "point", "plane"):  # a point's and a plane's descriptions are optional guesses
        RECORD_KINDS[name].check_described(empty, "x1", 0)
