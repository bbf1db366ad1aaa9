"""A pose design's request against references (anchors, points, planes, cameras) as the candidate record
groups of `optimal_design.references`: which reference each candidate (and each record already measured,
`fixed`) measures, the filters the service applies before the design (joint sub-ranges, the keep-out box, an
anchor's readable range, what a camera would see), and the options it refuses.

The design takes the tracker's options (records already measured, a minimum spread, a D-efficiency floor, branch
and bound) but model terms (the reference fit evaluates the robot without a record's temperature or load), a cell
and a fleet's prior (a tracker's for now): those are refused here with the reason, never ignored.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from models import RobotDescription, forward_kinematics, sample_workspace
from models._types import Array
from models.engine.runtime import Runtime
from models.errors import InvalidInput, TooFewMeasurements
from models.kinematics import check_joint_ranges
from models.measurements.references import ReferenceRecords
from optimal_design.constraints import KeepOut, joint_range_mask, keep_out_mask
from optimal_design.problem import MAX_CANDIDATES
from service.conversions.designs import constraints_in
from service.conversions.kinematics import joints_in
from service.record_kinds import BY_REFERENCE, RECORD_KINDS, REFERENCE_KINDS, ReferenceCandidate, described
from service.record_kinds.base import ModelReference
from service.schemas.designs import PoseDesignCreate

KIND_OF_MEASUREMENT = {kind.name: name for name, kind in BY_REFERENCE.items()}
"""The reference kind a record kind measures (records say `anchor`, `point`, `plane`, `camera`)."""
PLURAL = {name: str(kind.described_in) for name, kind in BY_REFERENCE.items()}
"""Where the body describes each kind."""
PLANNED = ", ".join(REFERENCE_KINDS[:-1]) + f" and {REFERENCE_KINDS[-1]}"
"""The kinds a reference design plans, as its messages list them."""
SAMPLED_KINDS = tuple(name for name, kind in BY_REFERENCE.items() if kind.sampled)
"""What sampled poses are offered against (`RecordKind.sampled`)."""


@dataclass(frozen=True)
class ReferenceCandidates:
    """The admissible candidates grouped by reference (the core's order: one group after the other), with,
    for each in that order, its index among the candidates given or sampled and its reference's name."""

    groups: tuple[ReferenceRecords, ...]
    origin: NDArray[np.intp]
    names: tuple[str, ...]
    offered: int
    """Candidates before the filters (a sampled pose counts once per anchor it is offered against)."""
    excluded: dict[str, int]
    fixed: tuple[ReferenceRecords, ...] = ()
    """The records already measured, grouped by reference (each reference once)."""


def refuse_unsupported(body: PoseDesignCreate) -> None:
    """The options the reference design does not take: a 422 naming each, with why and what to do."""
    no_terms = (
        f"{PLANNED} records are fitted without a temperature or load per record (the reference fit has no model "
        "terms): design them without terms, or design the terms' poses with a tracker's records (pose or position)"
    )
    refused = {
        "cell": body.cell is not None
        and "designs among the poses a cell can measure are of a tracker's records (pose or position) for now",
        "prior": body.prior != "none"
        and "fleet designs tracker poses: a reference campaign's fit takes no prior yet; omit it",
        "terms": bool(body.terms) and no_terms,
        "temperature_levels_c": body.temperature_levels_c is not None
        and "levels belong to a design with terms; omit them",
        "payload_levels": body.payload_levels is not None and "levels belong to a design with terms; omit them",
    }
    for name, why in refused.items():
        if why:
            raise InvalidInput(f"{name}: {why} (measurement {body.measurement!r})", field=name, reason="unsupported")


def references_in(body: PoseDesignCreate) -> dict[tuple[str, str], ModelReference]:
    """Every described reference by (kind, name), as the design needs it: an anchor where it stands, a plane's
    normal, a camera's pose. A 422 naming the one that lacks what the design needs."""
    found: dict[tuple[str, str], ModelReference] = {}
    describes = described(body)
    for candidate, kind in BY_REFERENCE.items():
        for name, description in kind.descriptions(describes).items():
            found[(candidate, name)] = kind.design_reference(name, description)
    names = [name for _, name in found]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise InvalidInput(
            f"reference names repeat across anchors, points, planes and cameras: {repeated}; name each once",
            field="anchors",
            value=repeated[0],
        )
    return found


@dataclass(frozen=True)
class _Request:
    """What the candidates are built from: the robot at its current parameters, the body and its references."""

    desc: RobotDescription
    theta: Array
    body: PoseDesignCreate
    references: dict[tuple[str, str], ModelReference]
    runtime: Runtime
    descriptions: dict[tuple[str, str], Any]
    """Each reference's description as the body gives it, by (kind, name) as `references`."""


def reference_candidates_in(
    desc: RobotDescription, theta: Array, body: PoseDesignCreate, runtime: Runtime
) -> ReferenceCandidates:
    """The candidate groups of a reference design: the given candidates by the reference each names, or poses
    sampled in the workspace offered against every anchor (a distance design only); then the checks that every
    reference can be determined and that a length is among them."""
    references = references_in(body)
    describes = described(body)
    descriptions = {key: BY_REFERENCE[key[0]].descriptions(describes)[key[1]] for key in references}
    request = _Request(desc, theta, body, references, runtime, descriptions)
    fixed = _fixed(request)
    found = _given(request, fixed) if body.candidates is not None else _sampled(request)
    found = replace(found, fixed=fixed)
    _check_determined(found, references, given=body.candidates is not None)
    return found


def _fixed(request: _Request) -> tuple[ReferenceRecords, ...]:
    """The records already measured, by the reference each names (a bare joint vector: the measurement's one),
    as the records the design would plan at their poses (a camera's: the points it sees there). No filter
    applies: they were measured."""
    desc, body, references = request.desc, request.body, request.references
    if not body.fixed:
        return ()
    tags = [_reference_of(body, references, i, c, what="fixed") for i, c in enumerate(body.fixed)]
    joints = joints_in(desc, [c.joints if isinstance(c, ReferenceCandidate) else c for c in body.fixed])
    check_joint_ranges(desc, joints)
    forward_kinematics(desc, joints, request.theta, runtime=request.runtime)  # UnreachablePose names the first
    groups = []
    for key, reference in references.items():
        mine = np.asarray([i for i, tag in enumerate(tags) if tag == key], dtype=np.intp)
        if mine.size == 0:
            continue
        group, _ = BY_REFERENCE[key[0]].design_records(
            desc, reference, request.descriptions[key], joints[mine], theta=request.theta, runtime=request.runtime
        )
        if group.size:
            groups.append(group)
    return tuple(groups)


def _filters(request: _Request, joints: Array) -> tuple[NDArray[np.bool_], dict[str, int]]:
    """Which poses pass the joint sub-ranges and the keep-out box, and how many each excluded (as the tracker
    design's filters count them: a pose once, by the first filter that removes it)."""
    desc = request.desc
    ranges, box = constraints_in(desc, request.body)
    ok = np.ones(joints.shape[0], dtype=bool)
    excluded: dict[str, int] = {}
    if ranges:
        inside = joint_range_mask(desc, joints, ranges)
        excluded["joint_ranges"] = int((~inside).sum())
        ok &= inside
    if box is not None:
        clear = keep_out_mask(desc, joints, KeepOut.of(box), request.theta, runtime=request.runtime)
        excluded["keep_out"] = int((ok & ~clear).sum())
        ok &= clear
    return ok, excluded


def _given(request: _Request, fixed: tuple[ReferenceRecords, ...]) -> ReferenceCandidates:
    desc, body, references = request.desc, request.body, request.references
    assert body.candidates is not None
    if not body.candidates:
        raise InvalidInput("candidates is empty: give at least `count` joint vectors, or omit them", field="candidates")
    tags = [_reference_of(body, references, i, c, what="candidate") for i, c in enumerate(body.candidates)]
    rows = [c.joints if isinstance(c, ReferenceCandidate) else c for c in body.candidates]
    joints = joints_in(desc, rows)
    check_joint_ranges(desc, joints)
    # UnreachablePose names the first one outside
    forward_kinematics(desc, joints, request.theta, runtime=request.runtime)
    ok, excluded = _filters(request, joints)
    by_reference: dict[tuple[str, str], list[int]] = {key: [] for key in references}
    for i, tag in enumerate(tags):
        if ok[i]:
            by_reference[tag].append(i)
    measured = {g.reference.name for g in fixed}  # a reference measured so far needs no candidate
    named = set(tags) | {key for key in references if key[1] in measured}
    missing = [key for key in references if key not in named]
    if missing:
        kind, name = missing[0]
        raise InvalidInput(
            f"{kind} {name!r} is described but no candidate names it: remove it, or give its candidates "
            f'({{"joints": [...], "{kind}": "{name}"}})',
            field="candidates",
            value=name,
            reason="unused_reference",
        )
    return _grouped(request, by_reference, joints, offered=len(rows), excluded=excluded)


def _reference_of(
    body: PoseDesignCreate,
    references: dict[tuple[str, str], ModelReference],
    index: int,
    candidate: list[float] | ReferenceCandidate,
    *,
    what: str,
) -> tuple[str, str]:
    """The (kind, name) of the reference a given candidate's record would measure (`what`: "candidate"), or a
    fixed record measured ("fixed")."""
    if isinstance(candidate, ReferenceCandidate):
        kind, name = candidate.reference
        if (kind, name) not in references:
            plural = PLURAL[kind]
            needs = BY_REFERENCE[kind].design_description
            raise InvalidInput(
                f'{what} {index} names {kind} {name!r}, which the body does not describe: add "{plural}": '
                f'{{"{name}": {needs}}}',
                field="candidates" if what == "candidate" else what,
                value=name,
                reason="undescribed_reference",
            )
        return kind, name
    kind = KIND_OF_MEASUREMENT[str(body.measurement)]
    mine = [key for key in references if key[0] == kind]
    if len(mine) != 1:
        raise InvalidInput(
            f"{what} {index} is a bare joint vector, which belongs to the one {kind} of measurement "
            f"{body.measurement!r}; the body describes {len(mine)}: say which, "
            f'{{"joints": [...], "{kind}": "<name>"}}',
            field="candidates" if what == "candidate" else what,
            reason="ambiguous_reference",
        )
    return mine[0]


def _sampled(request: _Request) -> ReferenceCandidates:
    """`candidate_count` workspace poses, each offered against every anchor where the nominal TCP's distance
    to it lies in the anchor's `range_mm`, and against every camera (kept where it sees a target, `_grouped`).
    Sampling cannot put the TCP on a point or a plane: those need candidates."""
    desc, theta, body, references = request.desc, request.theta, request.body, request.references
    _check_samplable(body, references)
    joints = sample_workspace(desc, body.candidate_count, seed=body.seed, params=theta, runtime=request.runtime)
    ok, per_pose = _filters(request, joints)
    tcp = forward_kinematics(desc, joints, theta, runtime=request.runtime).positions
    by_reference: dict[tuple[str, str], list[int]] = {}
    unreadable: dict[str, int] = {}  # by each kind's filter (`RecordKind.readable_filter`: an anchor's range_mm)
    for key, reference in references.items():
        keep = ok.copy()
        kind = BY_REFERENCE[key[0]]
        readable = kind.readable(reference, request.descriptions[key], tcp)
        if readable is not None and kind.readable_filter is not None:
            unreadable[kind.readable_filter] = unreadable.get(kind.readable_filter, 0) + int((keep & ~readable).sum())
            keep &= readable
        by_reference[key] = [int(i) for i in np.flatnonzero(keep)]
    excluded = {why: n * len(references) for why, n in per_pose.items()} | unreadable
    offered = joints.shape[0] * len(references)
    return _grouped(request, by_reference, joints, offered=offered, excluded=excluded)


def _check_samplable(body: PoseDesignCreate, references: dict[tuple[str, str], ModelReference]) -> None:
    """Sampled candidates need references they can be offered against, and at most MAX_CANDIDATES of them."""
    record_kind = RECORD_KINDS.get(str(body.measurement))
    sampled = record_kind is not None and record_kind.sampled
    if not sampled or any(kind not in SAMPLED_KINDS for kind, _ in references):
        raise InvalidInput(
            f"measurement {body.measurement!r}: sampled poses do not put the TCP on a point or a plane; give "
            'candidates, joint vectors that put the TCP on it ({"joints": [...], "point": "<name>"} or "plane")'
            + (", or design distance and image records alone" if sampled else ""),
            field="candidates",
            reason="candidates_needed",
        )
    assert record_kind is not None  # sampled
    measured = KIND_OF_MEASUREMENT[record_kind.name]
    if not any(kind == measured for kind, _ in references):
        # Sampled poses offered to none of the measured kind would design records of another kind under its name.
        plural = PLURAL[measured]
        describe = f'"{plural}": {{"{record_kind.example_name}": {record_kind.design_description}}}'
        raise InvalidInput(
            f"measurement {body.measurement!r}: describe the {plural} the records would measure: {describe}",
            field=plural,
        )
    if body.candidate_count * len(references) > MAX_CANDIDATES:
        raise InvalidInput(
            f"candidate_count {body.candidate_count} offered against {len(references)} anchors and cameras is "
            f"{body.candidate_count * len(references)} candidates: at most {MAX_CANDIDATES}; lower candidate_count",
            field="candidate_count",
            max=MAX_CANDIDATES // len(references),
        )


def _grouped(
    request: _Request,
    by_reference: dict[tuple[str, str], list[int]],
    joints: Array,
    *,
    offered: int,
    excluded: dict[str, int],
) -> ReferenceCandidates:
    """The groups in the references' order (anchors, points, planes, cameras as described), the empty ones left
    out; a camera's poses that see none of its targets counted in `excluded.not_seen`."""
    groups, origin, names = [], [], []
    excluded = dict(excluded)
    for key, reference in request.references.items():
        index = np.asarray(by_reference.get(key, []), dtype=np.intp)
        if index.size == 0:
            continue
        kind = BY_REFERENCE[key[0]]
        group, at = kind.design_records(
            request.desc,
            reference,
            request.descriptions[key],
            joints[index],
            theta=request.theta,
            runtime=request.runtime,
        )
        record_origin = index[at]
        # The core weighs one candidate per distinct joint vector of a group, in the order they first appear
        # (`optimal_design.references`: an image's points are one stop); each is named by its first record's.
        _, first = np.unique(group.joints, axis=0, return_index=True)
        stops = record_origin[np.sort(first)]
        if kind.unseen_filter is not None:
            unseen = int(np.isin(index, record_origin, invert=True).sum())  # a repeated pose is not unseen
            excluded[kind.unseen_filter] = excluded.get(kind.unseen_filter, 0) + unseen
        groups.append(group)
        origin.append(stops)
        names.extend([reference.name] * stops.size)
    if not groups:
        raise InvalidInput(
            f"no candidate passes the filters (of {offered} offered: "
            f"{', '.join(f'{n} {why}' for why, n in excluded.items())})",
            field="candidates",
            reason="all_filtered",
        )
    return ReferenceCandidates(
        groups=tuple(groups),
        origin=np.concatenate(origin),
        names=tuple(names),
        offered=offered,
        excluded=excluded,
    )


def _check_determined(
    found: ReferenceCandidates, references: dict[tuple[str, str], ModelReference], *, given: bool
) -> None:
    """Enough admissible candidates for each reference to be determined, and a length among them: a 4xx in a
    design's words (the core would speak of records measured)."""
    sizes = {g.reference.name: g.size for g in found.groups}
    for done in found.fixed:  # what was measured counts towards determining its reference
        sizes[done.reference.name] = sizes.get(done.reference.name, 0) + done.size
    for (kind, name), reference in references.items():
        have, needed = sizes.get(name, 0), reference.minimum_records
        if have < needed:
            record_kind = BY_REFERENCE[kind]
            fix = "give more candidates naming it" if given else record_kind.more_candidates
            has = record_kind.design_has(have)  # a camera's records are the points its images would show
            raise TooFewMeasurements(
                f"{kind} {name!r} {has}: a design needs at least {needed} to determine its "
                f"{len(reference.unknowns)} unknowns; {fix}",
                got=have,
                needed=needed,
                missing=needed - have,
                kind=kind,
            )
    if not any(g.reference.traits.fixes_scale for g in (*found.groups, *found.fixed)):
        raise InvalidInput(
            "fixed points and planes fix no length (the robot and its points and planes scaled together fit them "
            "as well): describe an anchor (a ballbar pivot) and add candidates naming it, "
            '{"joints": [...], "anchor": "a1"}, so that the design mixes distance records in',
            field="candidates",
            reason="no_length_scale",
        )
