"""A calibration's campaign read from its request: JSON, one CSV, or a joint file and a point file (multipart),
with what the query adds to a file (`CampaignQuery`). Large bodies parse off the event loop."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import anyio
from fastapi import Query, Request
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError
from python_multipart.exceptions import FormParserError

from models.identification.drift import MAX_DEGREE, DriftDriver
from models.parameters import Kind
from models.urdf import urdf_joint_names
from service.campaign_io import ImportOptions, QuaternionOrder
from service.campaign_io.columns import RobotColumns, parse_column_map
from service.campaign_io.encoding import decode_text
from service.campaign_io.reference_table import anchor_names
from service.campaign_io.tabular import normalise
from service.conversions.robots import description, urdf_source
from service.csv_codec import joined_campaign, parse_campaign
from service.errors import BadRequest, UnsupportedMediaType
from service.guards import MAX_DEPTH, OFFLOOP_BYTES, too_deep
from service.persistence.database import Database
from service.persistence.repository import Repository
from service.schemas.calibrations import CalibrationCreate


@dataclass(frozen=True)
class CampaignQuery:
    """What the query adds to a campaign sent as a file (CSV or multipart), where the body has no field for it;
    `apply` overrides a JSON body's too."""

    apply: bool | None
    noise_position_mm: float | None
    noise_orientation_deg: float | None
    file_options: ImportOptions
    terms: list[str] | None
    payload_kg: float | None
    payload_cog_mm: list[float] | None
    length_unknown: list[str]
    drift: DriftDriver | None = None
    drift_degree: int = 1
    prior: Literal["none", "fleet"] | None = None


def campaign_query(  # Long on purpose: one FastAPI dependency, a Query declaration per parameter a file needs
    *,
    apply: bool | None = Query(None, description="Override the body's 'apply' (useful with CSV)"),
    noise_position_mm: float | None = Query(None, gt=0, le=1000, description="σ position, CSV bodies"),
    noise_orientation_deg: float | None = Query(None, gt=0, le=180, description="σ orientation, CSV bodies"),
    length_unit: Literal["mm", "m", "cm", "um", "in"] = Query(
        "mm", description="CSV bodies: unit of x, y, z and sigma where the header does not state one ('X [m]')"
    ),
    quaternion_order: QuaternionOrder = Query(
        QuaternionOrder.WXYZ, description="CSV bodies: of q0…q3 columns (Leica-style); qw/qx/qy/qz name themselves"
    ),
    terms: list[Literal["thermal", "compliance"]] | None = Query(
        None, description="CSV bodies: options.terms (the temperature_c column feeds the thermal term)"
    ),
    payload_kg: float | None = Query(None, ge=0, le=10_000, description="CSV bodies: the campaign's payload mass"),
    payload_cog_mm: list[float] | None = Query(
        None, min_length=3, max_length=3, description="CSV bodies: its centre of gravity x, y, z (tool frame, mm)"
    ),
    length_unknown: list[str] | None = Query(
        None,
        max_length=100,
        description="CSV bodies with distance records: the anchors whose bar length offset is unknown (identified)",
    ),
    drift: DriftDriver | None = Query(
        None,
        description="CSV bodies: options.drift's driver (the time and reference columns feed it; docs/drift.md)",
    ),
    drift_degree: int = Query(1, ge=1, le=MAX_DEGREE, description="CSV bodies: options.drift's degree"),
    prior: Literal["none", "fleet"] | None = Query(
        None, description="CSV bodies: options.prior (fleet: calibrate with the robot's fleet's population)"
    ),
    columns: str | None = Query(
        None,
        max_length=10_000,
        description="CSV and multipart bodies: the column map, FILE_COLUMN=MEANING entries separated by commas "
        "(J1=joint_1,J2=joint_2,X_m=x): a meaning is a joint of the robot (q1 … or its URDF's joint names, which a "
        "header may also use unmapped) or x, y, z, qw, qx, qy, qz, pose_id, sigma_mm, u95, temperature_c, time, "
        "reference, reflector",
    ),
    joint_unit: Literal["deg", "rad"] | None = Query(
        None,
        description="CSV and multipart bodies: the revolute joint columns' unit where the header states none "
        "(a header says it as 'A1 [rad]', 'A1 (rad)' or 'a1_rad'); default deg",
    ),
) -> CampaignQuery:
    return CampaignQuery(
        apply,
        noise_position_mm,
        noise_orientation_deg,
        ImportOptions(
            length_unit=length_unit,
            quaternion_order=quaternion_order,
            columns=parse_column_map(columns),
            joint_unit=joint_unit,
        ),
        list(terms) if terms else None,
        payload_kg,
        payload_cog_mm,
        list(length_unknown or []),
        drift,
        drift_degree,
        prior,
    )


async def campaign_body(
    request: Request, query: CampaignQuery, robot: Callable[[], RobotColumns] | None = None
) -> CalibrationCreate:
    """The campaign as JSON, as one CSV, or as the controller's joint file and the instrument's point file
    (multipart: `joints`, `points`, optional `points_format`), with noise and apply from the query. `robot`
    gives the robot's joint names (its URDF's too) when a file is to be read: a JSON body never needs them."""
    content_type = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    raw = await request.body()
    try:
        if content_type in ("text/csv", "multipart/form-data"):
            if content_type == "text/csv":
                text, decoded = decode_text(raw, "the CSV body")
                # Off the event loop, like the JSON body below: a large file parses for seconds.
                columns = None if robot is None else await anyio.to_thread.run_sync(robot)
                measurements, notes = await request.app.state.compute.call(
                    functools.partial(parse_campaign, text, options=query.file_options, robot=columns)
                )
                notes = [*([decoded] if decoded else []), *notes]
                described: dict[str, Any] = {}
            else:
                columns = None if robot is None else await anyio.to_thread.run_sync(robot)
                measurements, notes, described = await _files(request, query.file_options, columns)
            payload = _file_payload(measurements, notes, query)
            payload.update({k: {**payload.get(k, {}), **v} for k, v in described.items()})
            return await anyio.to_thread.run_sync(CalibrationCreate.model_validate, payload)
        if content_type in ("application/json", ""):
            # A large body in the parse process (100 000 records validate in 2.2 s here, in a thread holding the
            # GIL the event loop needs); a small one here, where a hop would cost more (64 kB: ~5 ms).
            parsed: CalibrationCreate | list[Any] = (
                await request.app.state.compute.call(_validate_json, raw)
                if len(raw) > OFFLOOP_BYTES
                else _validate_json(raw or b"null")
            )
            if isinstance(parsed, list):
                raise RequestValidationError(parsed)
            return parsed.model_copy(update={"apply": query.apply}) if query.apply is not None else parsed
    except ValidationError as exc:
        raise RequestValidationError(exc.errors(include_url=False, include_context=False)) from exc
    raise UnsupportedMediaType(
        f"send the campaign as application/json or text/csv, not {content_type!r}", content_type=content_type
    )


def _file_payload(measurements: list[dict[str, object]], notes: list[str], query: CampaignQuery) -> dict[str, Any]:
    """A file's records as a calibration body, with what the query adds (noise, apply, terms, payload, anchors)."""
    payload: dict[str, Any] = {"measurements": measurements, "import_notes": notes}
    anchors = anchor_names(measurements)
    if anchors or query.length_unknown:
        # A file names its anchors in its rows; the query says which bars' lengths are unknown.
        payload["anchors"] = {a: {"length_unknown": a in query.length_unknown} for a in anchors}
        payload["anchors"].update({a: {"length_unknown": True} for a in query.length_unknown})
    noise = {}
    if query.noise_position_mm is not None:
        noise["position_mm"] = query.noise_position_mm
    if query.noise_orientation_deg is not None:
        noise["orientation_deg"] = query.noise_orientation_deg
    if noise:
        payload["noise"] = noise
    if query.apply is not None:
        payload["apply"] = query.apply
    if query.terms:
        payload["options"] = {"terms": query.terms}
    if query.drift is not None:
        payload.setdefault("options", {})["drift"] = {"driver": query.drift.value, "degree": query.drift_degree}
    if query.prior is not None:
        payload["options"] = {**payload.get("options", {}), "prior": query.prior}
    if query.payload_kg is not None:
        payload["payload"] = {"mass_kg": query.payload_kg, "cog_mm": query.payload_cog_mm or [0.0, 0.0, 0.0]}
    return payload


def _validate_json(raw: bytes) -> CalibrationCreate | list[Any]:
    """The body as a CalibrationCreate, or its validation errors (plain data: this runs in a compute process)."""
    try:
        return CalibrationCreate.model_validate_json(raw)
    except ValidationError as exc:
        return list(exc.errors(include_url=False, include_context=False))


async def _files(
    request: Request, options: ImportOptions, robot: RobotColumns | None
) -> tuple[list[dict[str, object]], list[str], dict[str, Any]]:
    """A joint file and a point file (CSV, a Leica-style export, or SpatialAnalyzer's ASCII) joined by pose id;
    or one `records` file in the layout of several kinds with its references' `descriptions` (JSON: anchors,
    points, planes, cameras) beside it. The records, the reader's notes and the descriptions."""
    parts = {}
    decoded: list[str] = []
    try:
        async with request.form() as form:  # closes the spooled upload files when done
            names = ("records", "descriptions") if "records" in form else ("joints", "points")
            for name in names:
                part = form.get(name)
                if part is None and name == "descriptions":
                    continue
                if part is None:
                    raise BadRequest(
                        f"multipart campaigns are two files, 'joints' and 'points', or a 'records' file with its "
                        f"'descriptions'; '{name}' is missing"
                    )
                if isinstance(part, str):
                    parts[name] = part
                    continue
                parts[name], note = decode_text(await part.read(), f"the '{name}' file")
                decoded += [note] if note else []
            points_format = str(form.get("points_format") or "csv")
    except FormParserError as exc:
        # Starlette turns its own multipart errors into a 400 but lets the parser's escape (a 500); the base class:
        # the parser raises it bare where it starts (a boundary over 256 characters, refused by the body guard too).
        raise BadRequest(f"the multipart body is malformed: {exc}") from exc
    # Off the event loop, as a single CSV body is (the guard bounded the files' cells before: up to ~1 s of parsing).
    compute = request.app.state.compute
    if "records" in parts:
        descriptions = _descriptions(parts.get("descriptions"))
        measurements, notes = await compute.call(
            functools.partial(parse_campaign, parts["records"], options=options, robot=robot)
        )
        return measurements, [*decoded, *notes], descriptions
    if points_format not in ("csv", "spatial-analyzer"):
        raise BadRequest(f"points_format must be 'csv' or 'spatial-analyzer', not {points_format!r}")
    measurements, notes = await compute.call(
        functools.partial(
            joined_campaign,
            parts["joints"],
            parts["points"],
            spatial_analyzer=points_format != "csv",
            options=options,
            robot=robot,
        )
    )
    return measurements, [*decoded, *notes], {}


DESCRIBED = ("anchors", "points", "planes", "cameras")


def _descriptions(text: str | None) -> dict[str, Any]:
    """The `descriptions` part: a JSON object of the body's anchors, points, planes and cameras (validated with
    the body)."""
    if text is None:
        return {}
    depth = too_deep(text.encode())  # json.loads recurses: 100 000 "[" were a RecursionError, a 500
    if depth is not None:
        raise BadRequest(f"the 'descriptions' part is JSON nested {depth} levels deep; at most {MAX_DEPTH} are read")
    try:
        found = json.loads(text)
    except json.JSONDecodeError as exc:
        raise BadRequest(
            f"the 'descriptions' part is not JSON: {exc.msg} at line {exc.lineno}", line=exc.lineno
        ) from exc
    if not isinstance(found, dict) or not set(found) <= set(DESCRIBED):
        raise BadRequest(f"the 'descriptions' part is a JSON object of {', '.join(DESCRIBED)}")
    return found


def robot_columns(db: Database, robot_id: str) -> RobotColumns:
    """The robot's joints as its campaign files may name them: q1 … (robots.md) and, for a robot imported from
    a URDF (or a UR's kinematics file, through the URDF it makes), that URDF's joint names in the same order."""
    with db.reader() as s:
        robot = Repository(s).robot(robot_id)  # NotFound for an unknown robot, before any file is read
        desc = description(robot)
        source = urdf_source(robot)
    names = desc.joint_names
    revolute = frozenset(n for n, kind in zip(names, desc.joint_kinds, strict=True) if kind is Kind.ANGLE)
    if source is None:
        return RobotColumns(names, {}, revolute)
    urdf = urdf_joint_names(source.urdf, source.base_link, source.tip_link)
    if len(urdf) != len(names):  # a URDF robot is its chain's joints; should it ever differ, read q1 … only
        return RobotColumns(names, {}, revolute)
    return RobotColumns(names, {normalise(u): n for u, n in zip(urdf, names, strict=True)}, revolute)
