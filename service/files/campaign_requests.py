"""A campaign read from its request, for every operation that takes one (calibrations, validations, quick
checks): JSON, one CSV, or a joint file and a point file (multipart), read with the same options
(`file_options`), with what each operation's query adds to a file (a calibration's: `CampaignQuery`). Large bodies
parse off the event loop."""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, Literal, TypeVar

import anyio
from fastapi import Depends, Query, Request
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ValidationError
from python_multipart.exceptions import FormParserError

from models.description.parameters import Kind
from models.formats.urdf import urdf_joint_names
from models.identification.drift import MAX_DEGREE, DriftDriver
from service.campaign_io import ImportOptions, QuaternionOrder
from service.campaign_io.columns import RobotColumns, parse_column_map
from service.campaign_io.encoding import decode_text
from service.campaign_io.reference_table import anchor_names
from service.campaign_io.tabular import normalise
from service.conversions.robots import description, urdf_source
from service.errors import BadRequest, UnsupportedMediaType
from service.files.csv_codec import CAMPAIGN_HEADER, joined_campaign, parse_campaign
from service.http.guards import MAX_DEPTH, OFFLOOP_BYTES, too_deep
from service.http.json_bodies import validate_json
from service.persistence.database import Database
from service.persistence.repository import Repository
from service.schemas.calibrations import CalibrationCreate

M = TypeVar("M", bound=BaseModel)
FILE_TYPES = ("text/csv", "multipart/form-data")


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


def file_options(
    *,
    length_unit: Literal["mm", "m", "cm", "um", "in"] = Query(
        "mm",
        description="CSV bodies: unit of x, y, z, sigma and the prismatic joint columns where the header does not "
        "state one ('X [m]'); a row of several points (x1, y1, z1, x2 …) is read in it too",
    ),
    quaternion_order: QuaternionOrder = Query(
        QuaternionOrder.WXYZ, description="CSV bodies: of q0…q3 columns (Leica-style); qw/qx/qy/qz name themselves"
    ),
    columns: str | None = Query(
        None,
        max_length=10_000,
        description="CSV and multipart bodies: the column map, FILE_COLUMN=MEANING entries separated by commas "
        "(J1=joint_1,J2=joint_2,X_m=x): a meaning is a joint of the robot (q1 … or its URDF's joint names, which a "
        "header may also use unmapped) or x, y, z, qw, qx, qy, qz, pose_id, sigma_mm, u95, temperature_c, time, "
        "reference, reflector, or x2, y2, z2 … for a row's further points (a row of several points: the TCP's is "
        "x1 … or the one mapped to x, y, z, the others become reflector records)",
    ),
    joint_unit: Literal["deg", "rad"] | None = Query(
        None,
        description="CSV and multipart bodies: the revolute joint columns' unit where the header states none "
        "(a header says it as 'A1 [rad]', 'A1 (rad)' or 'a1_rad'); default deg",
    ),
) -> ImportOptions:
    """How a campaign file is read (a FastAPI dependency): the same options wherever a campaign may be a file
    (calibrations, validations, quick checks)."""
    return ImportOptions(
        length_unit=length_unit,
        quaternion_order=quaternion_order,
        columns=parse_column_map(columns),
        joint_unit=joint_unit,
    )


FileOptions = Annotated[ImportOptions, Depends(file_options)]


def campaign_query(  # Long on purpose: one FastAPI dependency, a Query declaration per parameter a file needs
    *,
    apply: bool | None = Query(None, description="Override the body's 'apply' (useful with CSV)"),
    noise_position_mm: float | None = Query(None, gt=0, le=1000, description="σ position, CSV bodies"),
    noise_orientation_deg: float | None = Query(None, gt=0, le=180, description="σ orientation, CSV bodies"),
    options: FileOptions,
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
) -> CampaignQuery:
    return CampaignQuery(
        apply,
        noise_position_mm,
        noise_orientation_deg,
        options,
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
    """A calibration's campaign (`campaign_request`), with noise, apply, terms, payload, anchors, drift and prior
    from the query; `apply` overrides a JSON body's too."""
    body = await campaign_request(
        request, CalibrationCreate, query.file_options, functools.partial(calibration_fields, query=query), robot
    )
    return body.model_copy(update={"apply": query.apply}) if query.apply is not None else body


async def campaign_request(
    request: Request,
    model: type[M],
    options: ImportOptions,
    fields: Callable[[list[dict[str, object]]], dict[str, Any]],
    robot: Callable[[], RobotColumns] | None = None,
) -> M:
    """A request whose body is a campaign (a calibration, a validation, a quick check): `model` as JSON, or its
    records read from one CSV, or from the controller's joint file and the instrument's point file (multipart:
    `joints`, `points`, optional `points_format`), or from a `records` file in the layout of several kinds with
    its `descriptions`. A file's body is its records, what the reader noted (`import_notes`) and `fields` (what
    the query adds, from the records read). `robot` gives the robot's joint names (its URDF's too) when a file is
    to be read: a JSON body never needs them."""
    content_type = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    try:
        if content_type in FILE_TYPES:
            columns = None if robot is None else await anyio.to_thread.run_sync(robot)
            measurements, notes, described = await _read_files(request, content_type, options, columns)
            payload = {"measurements": measurements, "import_notes": notes, **fields(measurements)}
            payload.update({k: {**payload.get(k, {}), **v} for k, v in described.items()})
            return await anyio.to_thread.run_sync(model.model_validate, payload)
        if content_type in ("application/json", ""):
            raw = await request.body()
            # A large body in the parse process (100 000 records validate in 2.2 s here, in a thread holding the
            # GIL the event loop needs); a small one here, where a hop would cost more (64 kB: ~5 ms).
            parsed = (
                await request.app.state.compute.call(validate_json, model, raw)
                if len(raw) > OFFLOOP_BYTES
                else validate_json(model, raw or b"null")
            )
            if isinstance(parsed, list):
                raise RequestValidationError(parsed)
            return parsed
    except ValidationError as exc:
        raise RequestValidationError(exc.errors(include_url=False, include_context=False)) from exc
    raise UnsupportedMediaType(
        f"send the campaign as application/json, text/csv or multipart/form-data, not {content_type!r}",
        content_type=content_type,
    )


async def _read_files(
    request: Request, content_type: str, options: ImportOptions, robot: RobotColumns | None
) -> tuple[list[dict[str, object]], list[str], dict[str, Any]]:
    """A file body's records, the reader's notes and its references' descriptions (a multipart `descriptions`)."""
    if content_type == "multipart/form-data":
        return await _files(request, options, robot)
    text, decoded = decode_text(await request.body(), "the CSV body")
    # Off the event loop, like a large JSON body: a large file parses for seconds.
    measurements, notes = await request.app.state.compute.call(
        functools.partial(parse_campaign, text, options=options, robot=robot)
    )
    return measurements, [*([decoded] if decoded else []), *notes], {}


def query_fields(fields: dict[str, Any]) -> Callable[[list[dict[str, object]]], dict[str, Any]]:
    """What the query adds to a validation or a quick check read from a file (`fields`: the body's fields a file
    has no column for, None where the query leaves one out: the body's default) and the anchors its records
    name, described as unknown (their place is fitted, as a calibration's file's anchors are; a multipart
    `descriptions` part says more)."""
    given = {k: v for k, v in fields.items() if v is not None}

    def fields_of(measurements: list[dict[str, object]]) -> dict[str, Any]:
        anchors = anchor_names(measurements)
        return {**({"anchors": {a: {} for a in anchors}} if anchors else {}), **given}

    return fields_of


def calibration_fields(measurements: list[dict[str, object]], query: CampaignQuery) -> dict[str, Any]:
    """What the query adds to a calibration read from a file: noise, apply, terms, payload, drift, prior, and the
    anchors its records name."""
    payload: dict[str, Any] = {}
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


def campaign_request_body(model: type[BaseModel]) -> dict[str, Any]:
    """`openapi_extra` of a route that reads a campaign itself (`campaign_request`): its body as JSON (`model`,
    added to the components by service.http.openapi), one CSV, or multipart files."""
    return {
        "requestBody": {
            "required": True,
            "content": {
                "application/json": {"schema": {"$ref": f"#/components/schemas/{model.__name__}"}},
                "text/csv": {
                    "schema": {"type": "string", "description": "header " + ",".join(CAMPAIGN_HEADER)},
                    "example": ",".join(CAMPAIGN_HEADER) + "\n400,150,90,45,420,420,420,420,420,420,1,2,3,1,0,0,0\n",
                },
                "multipart/form-data": {
                    "schema": {
                        "type": "object",
                        "required": ["joints", "points"],
                        "properties": {
                            "joints": {
                                "type": "string",
                                "format": "binary",
                                "description": "pose id + joint columns",
                            },
                            "points": {
                                "type": "string",
                                "format": "binary",
                                "description": "pose id + x, y, z (CSV, Leica-style) or a SpatialAnalyzer export",
                            },
                            "points_format": {"type": "string", "enum": ["csv", "spatial-analyzer"], "default": "csv"},
                        },
                    }
                },
            },
        }
    }
