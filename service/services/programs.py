"""Program compensation: read a program's targets (`programs`), correct them for a parameter version
(`models.compensation.compensate_poses`) and write them back into the program's own text."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from models import Registry, RobotDescription
from models._types import Array
from models.compensation.controller import ZERO, ControllerFrame, urdf_controller_frame
from models.compensation.pendant import check_pendant
from models.compensation.poses import PoseCompensation, compensate_poses
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.formats.ur_kinematics import BASE_LINK as UR_BASE_LINK
from models.inverse import default_seed
from models.transforms import matrix_to_rotvec_np, quaternion_to_matrix
from programs import DIALECTS, PROGRAM, Program, ProgramError, Target, dialect, dialect_of_file, read_program, rewritten
from programs.collection import collector_paused
from programs.configuration import kept
from programs.configuration import seed as configuration_seed
from service.compute import limits
from service.compute.model_cache import ModelCache
from service.conversions.drift import condition_warnings
from service.conversions.kinematics import joints_in
from service.conversions.robots import description, urdf_source
from service.conversions.terms import stored_model
from service.persistence import Database, Repository
from service.schemas.common import ConditionWarningPublic
from service.schemas.programs import CompensatedTarget, PendantCheckPublic, ProgramRequest, ProgramResponse
from service.services.hooks import JobHooks


@dataclass(frozen=True)
class TargetOutcome:
    target: Target
    pose: Array | None
    """The corrected pose in the target's base frame (None: kept as written)."""
    reason: str | None
    branch: str | None = None
    """Where the nominal controller's joint solution was sought: what fixes the target's branch."""
    warning: str | None = None
    """Set where the program does not fix the branch the controller will take."""


@dataclass(frozen=True)
class CompensatedProgram:
    texts: dict[str | None, str]
    outcomes: tuple[TargetOutcome, ...]


def compensate_program(
    desc: RobotDescription,
    calibrated: ArrayLike,
    program: Program,
    *,
    nominal: ArrayLike | None = None,
    seed: Array | None = None,
    runtime: Runtime | None = None,
    controller: ControllerFrame = ZERO,
    deadline: float | None = None,
    progress: Callable[[float], None] | None = None,
) -> CompensatedProgram:
    """Every target of `program` corrected so that the calibrated robot's TCP lands where the nominal one's would
    (`nominal`: default the description's nominal parameters); the ones that cannot be keep their text.

    The program's frames start at the controller's base frame (`controller`: {0} <- it, the nominal
    geometry's), which for an imported robot is not the model's {0} (`models.compensation.controller`).

    `progress` (a job's): called with the fraction of the targets done after each batch of `JOB_BATCH` targets,
    which are then solved batch by batch (each target's solution is its own: the same answer as in one batch)."""
    # Objects per target (outcomes, arrays, rewritten numbers): without the cycle collector's passes over
    # them, as in reading (`programs.collection`).
    with collector_paused():
        active = [t for t in program.targets if t.kept is None]
        outcomes = {id(t): TargetOutcome(t, None, t.kept) for t in program.targets}
        if active:
            starts, branches = _starts(desc, active, seed)
            bases = controller.zero_from_controller @ np.array([t.frames.base for t in active])
            result = _solved(
                desc,
                calibrated,
                desc.parameters.nominal if nominal is None else nominal,
                bases @ np.array([t.pose for t in active]),
                tools=[t.frames.tool for t in active],
                seeds=np.array(starts),
                runtime=runtime,
                deadline=deadline,
                progress=progress,
            )
            in_base = np.linalg.solve(bases, result.poses)  # back into each target's own base frame
            for k, t in enumerate(active):
                held = t.configuration if t.configuration is not None and t.configuration.enforced else None
                why = result.reasons[k] or kept(held, result.nominal_joints[k], result.joints[k], desc.joint_names)
                branch, warning = branches[k]
                warning = "; ".join(w for w in (t.warning, warning) if w) or None  # the frames', then the branch's
                pose = None if why is not None else in_base[k]
                outcomes[id(t)] = TargetOutcome(t, pose, why, branch, warning if pose is not None else None)
        ordered = tuple(outcomes[id(t)] for t in program.targets)
        changes = [(o.target, o.pose) for o in ordered if o.pose is not None]
        return CompensatedProgram(rewritten(program, changes), ordered)


JOB_BATCH = 1000
"""Targets solved between two progress points of a job: ~0.1 s of work each on this machine, so a cancellation
is seen within a fraction of a second and the progress moves a few times a second."""


def _solved(
    desc: RobotDescription,
    calibrated: ArrayLike,
    nominal: ArrayLike,
    targets: Array,
    *,
    tools: Sequence[ArrayLike | None],
    seeds: Array,
    runtime: Runtime | None,
    deadline: float | None,
    progress: Callable[[float], None] | None,
) -> PoseCompensation:
    """`compensate_poses` on all the targets at once, or for a job batch by batch with a progress point after each
    (the batches' results joined in the targets' order)."""
    n = len(targets)
    if progress is None or n <= JOB_BATCH:
        found = compensate_poses(
            desc, calibrated, nominal, targets, tools=tools, seeds=seeds, runtime=runtime, deadline=deadline
        )
        if progress is not None:
            progress(1.0)
        return found
    parts: list[PoseCompensation] = []
    for start in range(0, n, JOB_BATCH):
        end = min(start + JOB_BATCH, n)
        parts.append(
            compensate_poses(
                desc,
                calibrated,
                nominal,
                targets[start:end],
                tools=tools[start:end],
                seeds=seeds[start:end],
                runtime=runtime,
                deadline=deadline,
            )
        )
        progress(end / n)
    return PoseCompensation(
        poses=np.concatenate([p.poses for p in parts]),
        reached=np.concatenate([p.reached for p in parts]),
        reasons=tuple(r for p in parts for r in p.reasons),
        nominal_joints=np.concatenate([p.nominal_joints for p in parts]),
        joints=np.concatenate([p.joints for p in parts]),
    )


UNDETERMINED = (
    "the program does not fix this target's configuration (no declared one the controller holds, no joint move "
    "before it): it was solved nearest the middle of the joint ranges, which may not be the branch the robot "
    "runs; give `seed` (the joints the robot is at) or put a joint move before it"
)


def _starts(
    desc: RobotDescription, active: list[Target], seed: Array | None
) -> tuple[list[Array], list[tuple[str, str | None]]]:
    """Per target the joints its nominal solution is sought from, and (what fixed them, a warning or None): the
    request's seed (an override), else the program's last joint move before it (the controller starts its solve
    from the arm's joints), else the middle of the ranges, with a warning unless the target declares a
    configuration the controller holds."""
    middle = default_seed(desc)
    revolute = all(k.boundary_unit != "mm" for k in desc.joint_kinds)
    starts: list[Array] = []
    branches: list[tuple[str, str | None]] = []
    held_text = "its declared configuration ({}), which the controller holds"
    for t in active:
        config = t.configuration
        declared = config is not None and config.enforced
        # A declared configuration the controller holds moves the start into it; one it does not hold (ConfL
        # \Off) only where nothing else says where the arm is.
        branch: tuple[str, str | None]
        if seed is not None:
            start, branch = seed, ("the request's seed", None)
        elif t.after is not None and revolute and len(t.after.joints) == desc.n_joints:
            start = np.clip(np.asarray(t.after.joints), desc.joint_min, desc.joint_max)
            branch = (f"the joint move at line {t.after.line}", None)
            config = config if declared else None
        elif declared:
            assert config is not None
            start, branch = middle, (held_text.format(config.text), None)
        else:
            start, branch = middle, ("the middle of the joint ranges", UNDETERMINED)
        starts.append(configuration_seed(config, start, desc.n_joints))
        branches.append(branch)
    return starts, branches


def _target_out(o: TargetOutcome) -> CompensatedTarget:
    t = o.target
    delta_mm = delta_deg = None
    if o.pose is not None:
        delta_mm = (o.pose[:3, 3] - t.pose[:3, 3]).tolist()
        turn = o.pose[:3, :3] @ t.pose[:3, :3].T
        delta_deg = np.degrees(matrix_to_rotvec_np(turn)).tolist()
    return CompensatedTarget(
        file=t.file,
        line=t.line,
        column=t.column,
        name=t.name,
        base_frame=t.frames.base_name,
        tool_frame=t.frames.tool_name,
        reached=o.pose is not None,
        correction_mm=delta_mm,
        correction_deg=delta_deg,
        reason=o.reason,
        branch=o.branch,
        warning=o.warning,
    )


def _model(db: Database, models: ModelCache, robot_id: str, version: int | None) -> tuple[RobotDescription, Array, int]:
    """The robot's model and the parameters of `version` (the current one by default)."""
    if version is None:
        desc, theta = models.current(robot_id)
        return desc, theta, db.current_version(robot_id) or 1
    with db.reader() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id)  # NotFound for an unknown robot
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
        return stored_model(description(robot), values.size), values, version


def compensate(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    body: ProgramRequest,
    job: JobHooks | None = None,
) -> ProgramResponse:
    """The program with its targets corrected; `job` (a worker's hooks): progress points while reading and after
    each batch of targets, and the time of a job (`JOB_SOLVE_S`) rather than a request's for the slow targets."""
    started = time.monotonic()
    if job is not None:
        job.progress("reading", 0.0)
    desc, theta, version = _model(db, models, robot_id, body.version)
    frame = controller_frame(db, robot_id)
    pendant = _pendant(desc, body, registry.runtime(desc), frame) if body.pendant else None
    seed = joints_in(desc, [body.seed])[0] if body.seed is not None else None
    # The request's own time: Newton's answers for every target, the costly general route only while time is
    # left, so an ordinary file is answered (its slow targets listed) rather than dropped at the compute deadline.
    deadline = started + (limits.PROGRAM_SOLVE_S if job is None else JOB_SOLVE_S)
    progress = None if job is None else _stage(job, "compensating", 0.05, 0.95)
    # A zero quaternion or a 1e300 value makes NaN or inf on the way, not an error: compensate_poses lists
    # such a target as not a pose or out of reach (numpy's warnings about them are noise here).
    with np.errstate(all="ignore"):
        program = read_program(body.format, body.program, body.files)
        if job is not None:
            job.progress("compensating", 0.05)
        done = compensate_program(
            desc,
            theta,
            program,
            seed=seed,
            runtime=registry.runtime(desc),
            controller=frame,
            deadline=deadline,
            progress=progress,
        )
    changed = {o.target.file for o in done.outcomes if o.pose is not None}
    return ProgramResponse(
        format=body.format,
        version=version,
        program=done.texts[PROGRAM],
        files={name: text for name, text in done.texts.items() if name is not None and name in changed},
        targets=[_target_out(o) for o in done.outcomes],
        pendant=pendant,
        warnings=_warnings(db, models, robot_id, version, body),
        controller_frame=frame.name,
    )


JOB_SOLVE_S = 0.5 * limits.JOB_MAX_S
"""A job's time for the targets Newton leaves to the general inverse kinematics (~0.3 s each): half of any job's
cap, so a program of many slow targets answers with those left listed rather than failing at the cap."""


def _stage(job: JobHooks, stage: str, low: float, high: float) -> Callable[[float], None]:
    """A job's progress through one stage: the stage's fraction done, mapped into [low, high] of the job."""
    return lambda done: job.progress(stage, low + (high - low) * done)


def compensate_as_job(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    body: ProgramRequest,
    encoding: str | None,
    job: JobHooks | None,
) -> str:
    """A program compensation run as a job: its answer (`compensate`, with the `encoding` a program sent as text
    was read in) stored with the job's own `succeeded`; the stored answer's id."""
    answer = compensate(db=db, models=models, registry=registry, robot_id=robot_id, body=body, job=job)
    if encoding is not None:
        answer = answer.model_copy(update={"encoding": encoding})
    if job is not None:
        job.progress("storing", 0.95)
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)  # still there
        record = repo.add_compensated_program(robot_id, answer.model_dump(mode="json"))
        if job is not None:
            job.commit(s, record.id)
        return record.id


def controller_frame(db: Database, robot_id: str) -> ControllerFrame:
    """The frame the robot's controller gives its targets in: {0} for a DH/MDH document or the IWR; for an
    imported URDF (or UR file) its root or ROS-Industrial's `base` (`models.compensation.controller`)."""
    with db.reader() as s:
        source = urdf_source(Repository(s).robot(robot_id))
    if source is None:
        return ZERO
    return urdf_controller_frame(
        source.urdf, source.base_link, source.tip_link, ur_file=source.base_link == UR_BASE_LINK
    )


def _warnings(
    db: Database, models: ModelCache, robot_id: str, version: int, body: ProgramRequest
) -> list[ConditionWarningPublic]:
    """The program's stated conditions against those `version` was calibrated under (read only when stated)."""
    if body.temperature_c is None and body.payload is None:
        return []
    if body.version is None:
        version, calibrated = models.conditions(robot_id)
    else:
        with db.reader() as s:
            calibrated = Repository(s).version(robot_id, version).conditions
    return condition_warnings(
        calibrated,
        version=version,
        temperatures=[] if body.temperature_c is None else [body.temperature_c],
        payloads_kg=[] if body.payload is None else [body.payload.mass_kg],
    )


def _pendant(
    desc: RobotDescription, body: ProgramRequest, runtime: Runtime, frame: ControllerFrame
) -> PendantCheckPublic:
    """The pendant readings against the nominal model (what the controller runs): a 422 naming what differs,
    before anything is compensated. A pendant displays poses in the controller's frame: taken into {0}."""
    readings = body.pendant
    joints = joints_in(desc, [r.joints for r in readings])
    into = frame.zero_from_controller
    positions = np.array([r.position for r in readings], dtype=float) @ into[:3, :3].T + into[:3, 3]
    with_orientation = all(r.orientation is not None for r in readings)
    rotations = (
        into[:3, :3] @ quaternion_to_matrix(np.array([r.orientation for r in readings])) if with_orientation else None
    )
    found = check_pendant(
        desc,
        desc.parameters.nominal,
        joints,
        positions,
        rotations,
        tolerance_mm=body.pendant_tolerance_mm,
        runtime=runtime,
    )
    if not found.agrees:
        raise InvalidInput(str(found.finding), field="pendant", reason="pendant_mismatch")
    turned = found.orientation_errors_rad
    return PendantCheckPublic(
        readings=len(readings),
        max_position_mm=float(found.position_errors_mm.max()),
        max_orientation_deg=None if turned is None else float(np.degrees(turned.max())),
    )


def decoded(raw: bytes) -> tuple[str, str]:
    """A program file's text and the encoding it was read in, as controllers write them: UTF-16 with its byte
    order mark (RobotStudio's exports), UTF-8 (a BOM kept as the text's first character: the readers skip it
    and the answer gives it back), else Windows-1252 (KUKA's KRC writes its .src and .dat so: ä, °, µ in
    comments). Bytes that are none of these are refused with where the first bad one is."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            return raw.decode("utf-16"), "utf-16"
        except UnicodeDecodeError as exc:
            raise ProgramError(
                f"the program starts with a UTF-16 byte order mark but is not UTF-16 text: {exc.reason} at byte "
                f"{exc.start}",
                reason="not-utf8",
            ) from None
    try:
        return raw.decode("utf-8"), "utf-8"
    except UnicodeDecodeError as exc:
        first = exc
    try:
        return raw.decode("cp1252"), "windows-1252"
    except UnicodeDecodeError:
        line = raw.count(b"\n", 0, first.start) + 1
        column = first.start - (raw.rfind(b"\n", 0, first.start) + 1) + 1
        raise ProgramError(
            f"the program is neither UTF-8, UTF-16 nor Windows-1252 text: byte 0x{raw[first.start]:02x} at offset "
            f"{first.start}; convert it to UTF-8 first",
            line=line,
            column=column,
            reason="not-utf8",
        ) from None


def request_from_text(
    raw: bytes, *, format_name: str | None, filename: str | None, version: int | None
) -> tuple[ProgramRequest, str]:
    """A program sent as the body itself (text/plain): its format from `?format=` or the file name's extension,
    and the encoding its bytes were read in (`decoded`)."""
    text, encoding = decoded(raw)
    name = format_name
    if name is None and filename:
        found = dialect_of_file(filename)
        name = found.name if found is not None else None
    if name is None:
        raise ProgramError(
            "say the program's format: ?format=krl|rapid|urscript|csv, or ?filename= with its extension",
            reason="unknown-format",
        )
    if name not in DIALECTS:
        dialect(name)  # the error naming the formats
    return ProgramRequest.model_validate({"format": name, "program": text, "version": version}), encoding


def compensate_text(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    raw: bytes,
    format_name: str | None,
    filename: str | None,
    version: int | None,
) -> ProgramResponse:
    body, encoding = request_from_text(raw, format_name=format_name, filename=filename, version=version)
    answer = compensate(db=db, models=models, registry=registry, robot_id=robot_id, body=body)
    return answer.model_copy(update={"encoding": encoding})
