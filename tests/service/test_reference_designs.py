"""Pose design for the instruments a cell owns, over HTTP: which ballbar (distance), socket (point) and plate
(plane) records to take. The API's design is the library's on the same candidates, it predicts no worse than
random records, a target design answers how many; records simulated at the chosen poses and calibrated through
the API reach what the design predicted; bad input is refused naming what to fix, and nothing is stored."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from harness.ballbar import PIVOTS, aligned_rms, gauge_truth, reaching
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like, ur5_like_document
from models.engine.runtime import runtime_for
from models.identification.options import IdentificationOptions
from models.identification.reference_fit import reference_problem
from models.measurements.references import Anchor, ReferenceRecords
from models.noise import NoiseModel
from models.workspace import workspace_samples
from optimal_design.information import WORKSPACE_POSES, WORKSPACE_SEED
from optimal_design.references import design_reference_records
from service.schemas.designs import PoseDesignCreate
from tests.service.helpers import assert_design_kept, calibrate_robot, finished_job

UR5 = ur5_like()
SIGMA_MM = 0.002
NOISE = {"position_mm": SIGMA_MM}
PER_ANCHOR = 40
NAMES = ("a1", "a2", "a3")


@pytest.fixture
def arm(client: TestClient) -> str:
    made = client.post("/v1/robots", json={"name": "ur5-ballbar-design", "structure": ur5_like_document()})
    assert made.status_code == 201, made.text
    return str(made.json()["id"])


def _candidate_joints() -> list[np.ndarray]:
    """Each anchor's candidate poses (internal units)."""
    return [sample_workspace(UR5, PER_ANCHOR, seed=300 + k) for k in range(len(NAMES))]


def _anchors(**extra: Any) -> dict[str, dict[str, Any]]:
    return {name: {"position_mm": pivot.tolist(), **extra} for name, pivot in zip(NAMES, PIVOTS, strict=True)}


def _tagged(joints: list[np.ndarray]) -> list[dict[str, Any]]:
    return [
        {"joints": q.tolist(), "anchor": name}
        for name, group in zip(NAMES, joints, strict=True)
        for q in group * UR5.joint_to_boundary
    ]


def _design(client: TestClient, arm: str, body: dict[str, Any]) -> dict[str, Any]:
    answer = client.post(f"/v1/robots/{arm}/pose-designs", json=body)
    assert answer.status_code == 201, answer.text
    return dict(answer.json())


def _calibrated_error(client: TestClient, arm: str, design: dict[str, Any], seed: int) -> float:
    """The chosen records simulated on a perturbed truth, calibrated through the API: the TCP error on fresh
    poses after the best rigid alignment (what records that fix no frame can be judged by), mm."""
    rng = np.random.default_rng(seed)
    truth = gauge_truth(UR5, seed)
    joints = np.asarray(design["poses"]) / UR5.joint_to_boundary
    pivots = dict(zip(NAMES, PIVOTS, strict=True))
    centres = np.array([pivots[name] for name in design["references"]])
    distances = np.linalg.norm(forward_kinematics(UR5, joints, truth).positions - centres, axis=1)
    distances += rng.normal(0, SIGMA_MM, distances.size)
    records = [
        {"kind": "distance", "joints": q, "anchor": name, "distance_mm": float(d)}
        for q, name, d in zip(design["poses"], design["references"], distances, strict=True)
    ]
    body = {"measurements": records, "anchors": {n: {} for n in NAMES}, "noise": NOISE, "apply": False}
    answer = calibrate_robot(client, arm, body)
    fitted = UR5.parameters.from_boundary([float(p["value"]) for p in answer["parameters"]])
    fresh = sample_workspace(UR5, 200, seed=77)
    return aligned_rms(
        forward_kinematics(UR5, fresh, fitted).positions, forward_kinematics(UR5, fresh, truth).positions
    )


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_d_design_of_30_ballbar_records_is_the_librarys_and_reaches_its_prediction(
    client: TestClient, arm: str
) -> None:
    joints = _candidate_joints()
    body = {
        "measurement": "distance",
        "count": 30,
        "criterion": "D",
        "candidates": _tagged(joints),
        "anchors": _anchors(),
        "noise": NOISE,
    }
    report = _design(client, arm, body)
    assert report["measurement"] == "distance" and report["count"] == 30
    metrics, baseline = report["metrics"], report["random_baseline"]
    assert metrics["predicted_rms_tcp_mm"] <= baseline["predicted_rms_tcp_mm"], (metrics, baseline)
    # The library on the same candidates (a fresh robot's current parameters are its nominal ones).
    groups = tuple(
        ReferenceRecords(Anchor(name, tuple(pivot)), group, np.zeros(PER_ANCHOR))
        for name, pivot, group in zip(NAMES, PIVOTS, joints, strict=True)
    )
    noise = NoiseModel(SIGMA_MM, math.radians(0.01))
    library = design_reference_records(UR5, groups, 30, "D", noise=noise, params=UR5.parameters.nominal)
    assert report["indices"] == list(library.indices)
    assert report["value"] == pytest.approx(library.value, abs=1e-9)
    assert metrics["predicted_rms_tcp_mm"] == pytest.approx(library.metrics["predicted_rms_tcp_mm"], abs=1e-9)
    assert report["references"] == [NAMES[i // PER_ANCHOR] for i in library.indices]
    assert report["constraints"]["offered"] == 3 * PER_ANCHOR and report["constraints"]["excluded"] == {}
    assert_design_kept(client, arm, report, "distance")
    # Close the loop: what the design predicts is what a calibration of those records reaches.
    reached = _calibrated_error(client, arm, report, seed=5)
    predicted = metrics["predicted_rms_tcp_mm"]
    assert predicted / 2 <= reached <= 2 * predicted, (reached, predicted)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_target_design_says_how_many_ballbar_records(client: TestClient, arm: str) -> None:
    goal = 0.0035  # 3.5 µm RMS at σ 2 µm: the minimum of records (28) predicts 4.7 µm
    body = {
        "measurement": "distance",
        "target": {"rms_tcp_mm": goal},
        "candidates": _tagged(_candidate_joints()),
        "anchors": _anchors(),
        "noise": NOISE,
    }
    report = _design(client, arm, body)
    assert report["criterion"] == "I" and report["measurement"] == "distance"
    assert report["metrics"]["predicted_rms_tcp_mm"] <= goal
    assert len(report["poses"]) == report["count"] == len(report["references"])
    curve = {p["count"]: p for p in report["curve"]}
    assert report["count"] > 28 and report["count"] - 1 in curve  # the answer is the smallest count:
    assert curve[report["count"] - 1]["I_rms_tcp_mm"] > goal  # one record fewer misses the target
    assert report["reachable_mm"] < goal


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_sampled_poses_are_offered_against_every_anchor_within_its_range(client: TestClient, arm: str) -> None:
    count = 150
    sampled = sample_workspace(UR5, count, seed=3, params=UR5.parameters.nominal)
    tcp = forward_kinematics(UR5, sampled, UR5.parameters.nominal).positions
    distance = np.linalg.norm(tcp[:, None, :] - PIVOTS[None], axis=2)
    readable = (400.0, 900.0)
    inside = (distance >= readable[0]) & (distance <= readable[1])
    body = {
        "measurement": "distance",
        "count": 30,
        "criterion": "I",
        "candidate_count": count,
        "seed": 3,
        "anchors": _anchors(range_mm=list(readable)),
        "noise": NOISE,
    }
    report = _design(client, arm, body)
    assert report["indices"] is None  # sampled: nobody's list
    assert report["constraints"]["offered"] == 3 * count
    assert report["constraints"]["excluded"] == {"range_mm": int((~inside).sum())}
    assert report["candidates"] == int(inside.sum())
    chosen = np.asarray(report["poses"]) / UR5.joint_to_boundary
    at = forward_kinematics(UR5, chosen, UR5.parameters.nominal).positions
    pivots = dict(zip(NAMES, PIVOTS, strict=True))
    reads = [np.linalg.norm(p - pivots[name]) for p, name in zip(at, report["references"], strict=True)]
    assert min(reads) >= readable[0] and max(reads) <= readable[1]


def test_joint_sub_ranges_filter_the_given_candidates_and_indices_stay_theirs(client: TestClient, arm: str) -> None:
    body = _ballbar(criterion="I", noise=NOISE, joint_ranges={"q1": [-120, 120]})
    q1 = np.array([c["joints"][0] for c in body["candidates"]])
    report = _design(client, arm, body)
    assert report["constraints"]["offered"] == q1.size
    assert report["constraints"]["excluded"] == {"joint_ranges": int((np.abs(q1) > 120).sum())}
    chosen = [body["candidates"][i] for i in report["indices"]]
    assert all(abs(c["joints"][0]) <= 120 for c in chosen)
    np.testing.assert_allclose([c["joints"] for c in chosen], report["poses"], atol=1e-9)
    assert [c["anchor"] for c in chosen] == report["references"]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_reference_design_runs_as_a_job_and_is_the_synchronous_one(client: TestClient, arm: str) -> None:
    body = _ballbar(criterion="D", noise=NOISE)
    accepted = client.post(f"/v1/robots/{arm}/pose-designs?async=true", json=body)
    assert accepted.status_code == 202, accepted.text
    job = finished_job(client, f"/v1/jobs/{accepted.json()['job_id']}")
    assert job["status"] == "succeeded", job
    direct = _design(client, arm, body)
    for key in ("indices", "references", "measurement", "value"):
        assert job["result"][key] == direct[key], key


def test_an_unreachable_target_is_said_in_the_records_words(client: TestClient, arm: str) -> None:
    body = _ballbar(count=None, target={"rms_tcp_mm": 1e-5}, noise=NOISE)
    answer = client.post(f"/v1/robots/{arm}/pose-designs", json=body)
    assert answer.status_code == 422, answer.text
    problem = answer.json()
    assert "candidate records" in problem["detail"] and "full pose" not in problem["detail"]
    assert problem["reachable_mm"] > 1e-5 and problem["candidates"] == 3 * PER_ANCHOR
    assert client.get(f"/v1/robots/{arm}/pose-designs").json() == []


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_socket_and_plate_records_are_designed_beside_a_ballbar(client: TestClient, arm: str) -> None:
    nominal = UR5.parameters.nominal
    socket = reaching(UR5, nominal, np.tile([350.0, 100.0, 200.0], (14, 1)), seed=2)[:10]
    rng = np.random.default_rng(4)
    on_plate = np.column_stack([rng.uniform(150, 450, 16), rng.uniform(-300, 300, 16), np.full(16, 120.0)])
    touches = reaching(UR5, nominal, on_plate, seed=11)[:12]
    deg = UR5.joint_to_boundary
    candidates = [
        *_tagged(_candidate_joints()),
        *({"joints": q.tolist(), "point": "s1"} for q in socket * deg),
        *({"joints": q.tolist(), "plane": "table"} for q in touches * deg),
    ]
    body = {
        "measurement": "point",
        "count": 40,
        "candidates": candidates,
        "anchors": _anchors(),
        "points": {"s1": {}},
        "planes": {"table": {"normal": [0, 0, 1]}},
        "noise": NOISE,
    }
    report = _design(client, arm, body)
    assert report["measurement"] == "point" and set(report["references"]) <= {*NAMES, "s1", "table"}
    assert "s1" in report["references"]  # the socket's records are worth taking beside the ballbar's
    np.testing.assert_allclose([candidates[i]["joints"] for i in report["indices"]], report["poses"], atol=1e-9)


def _ballbar(**extra: Any) -> dict[str, Any]:
    return {
        "measurement": "distance",
        "count": 30,
        "candidates": _tagged(_candidate_joints()),
        "anchors": _anchors(),
        **extra,
    }


def _few(body: dict[str, Any]) -> None:
    body["candidates"] = [c for c in body["candidates"] if c["anchor"] != "a2"] + [
        c for c in body["candidates"] if c["anchor"] == "a2"
    ][:3]


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda b: b["anchors"].pop("a2"), "which the body does not describe"),
        (lambda b: b["anchors"]["a1"].pop("position_mm"), "anchor 'a1': a design needs where it stands"),
        (lambda b: b["anchors"].update({"spare": {"position_mm": [0, 0, 900]}}), "no candidate names it"),
        (lambda b: b.update({"candidates": [c["joints"] for c in b["candidates"]]}), "say which"),
        (_few, "anchor 'a2' has 3 admissible candidates"),
        (lambda b: b.update({"terms": ["thermal"]}), "terms: distance, point, plane, image"),
        (lambda b: b.update({"temperature_levels_c": [20.0]}), "temperature_levels_c: levels belong to a design"),
        (lambda b: b.update({"cell": "stored"}), "cell: designs among the poses a cell can measure are of a tracker"),
        (lambda b: b.update({"prior": "fleet"}), "prior: fleet designs tracker poses"),
        (lambda b: b.update({"fixed": [b["candidates"][0]["joints"]]}), "fixed 0 is a bare joint vector"),
        (lambda b: b.update({"fixed": [{**b["candidates"][0], "anchor": "zz"}]}), "fixed 0 names anchor 'zz'"),
        (lambda b: b.update({"min_spread": 1.0}), "min_spread 1: only"),
        (lambda b: b.update({"d_efficiency_floor": 0.5}), "d_efficiency_floor applies to the"),
        (lambda b: b.update({"count": None, "target": {"rms_tcp_mm": 0.01}, "criterion": "E"}), "not E"),
        (lambda b: b.update({"candidates": None, "measurement": "point", "points": {"s1": {}}}), "give candidates"),
        (lambda b: b["anchors"]["a1"].update({"range_mm": [500, 100]}), "min < max"),
        (lambda b: b.update({"measurement": "position"}), "is a tracker's"),
        (
            lambda b: b.update(
                {
                    "measurement": "plane",
                    "anchors": {},
                    "planes": {"p1": {"normal": [0, 0, 1]}},
                    "candidates": [c["joints"] for c in b["candidates"]],
                }
            ),
            "fix no length",
        ),
        (
            lambda b: b.update(
                {
                    "planes": {"p1": {}},
                    "candidates": [*b["candidates"], {"joints": b["candidates"][0]["joints"], "plane": "p1"}],
                }
            ),
            "plane 'p1': a design needs its normal",
        ),
    ],
)
@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_bad_reference_designs_are_refused_naming_the_fix_and_nothing_is_stored(
    client: TestClient, arm: str, change: Any, words: str
) -> None:
    body = _ballbar()
    change(body)
    answer = client.post(f"/v1/robots/{arm}/pose-designs", json=body)
    assert answer.status_code == 422, answer.text
    assert words in answer.text, answer.text
    assert client.get(f"/v1/robots/{arm}/pose-designs").json() == []


def test_the_documented_request_bodies_are_valid_designs() -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "instruments.md").read_text()
    section = text[text.index("## Designing the records") :]
    bodies = [json.loads(block) for block in re.findall(r"```json\n(.*?)```", section, re.DOTALL)]
    assert [b["measurement"] for b in bodies] == ["distance", "point", "plane", "image"]
    for body in bodies:
        PoseDesignCreate.model_validate(body)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_rounding_that_loses_rank_starts_the_exchange_from_the_greedy_design(client: TestClient, arm: str) -> None:
    """An I design of 30 ballbar distances from 1 340 candidates per anchor (seed 1): its rounded relaxation was
    singular and the exchange's inverse of it answered 500. The design starts from the greedy one instead."""
    body = {"measurement": "distance", "count": 30, "criterion": "I", "candidate_count": 1340, "seed": 1}
    design = _design(client, arm, {**body, "anchors": _anchors(), "noise": NOISE})
    assert len(design["poses"]) == 30
    predicted = design["metrics"]["predicted_rms_tcp_mm"]
    assert math.isfinite(predicted) and predicted < 0.5 * design["random_baseline"]["predicted_rms_tcp_mm"]


def _by_hand(records: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(M, L, the robot parameters a fit of these records estimates) of a ballbar campaign (joints per anchor,
    internal units), from the fit's own Jacobian: M its information, L the mean TCP sensitivity over the
    workspace (zeros in the anchors' columns), so that trace(L M⁻¹) is the predicted mean TCP variance."""
    pivots = dict(zip(NAMES, PIVOTS, strict=True))
    groups = tuple(
        ReferenceRecords(Anchor(name, tuple(pivots[name])), q, np.zeros(len(q))) for name, q in records.items()
    )
    noise = NoiseModel(SIGMA_MM, math.radians(0.01))
    problem = reference_problem(
        UR5,
        groups,
        noise=noise,
        theta=UR5.parameters.nominal,
        estimate=IdentificationOptions().estimate,
        runtime=runtime_for(UR5),
    )
    evaluated = problem.evaluate(np.zeros(problem.n_free))
    assert evaluated is not None
    jacobian = evaluated.jacobian
    free = list(problem.free)
    workspace = workspace_samples(UR5, WORKSPACE_POSES, WORKSPACE_SEED)
    rows = forward_kinematics(UR5, workspace, jacobian=True).jacobians[:, :3, free] * UR5.parameters.scales[free]
    flat = rows.reshape(-1, len(free))
    task = np.zeros((problem.n_free,) * 2)
    task[: len(free), : len(free)] = flat.T @ flat / workspace.shape[0]
    return jacobian.T @ jacobian, task, [UR5.parameters.names[i] for i in free]


def _campaign(*tagged: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Tagged records (boundary units) as joints per anchor (internal units)."""
    records: dict[str, list[list[float]]] = {}
    for r in (r for group in tagged for r in group):
        records.setdefault(r["anchor"], []).append(r["joints"])
    return {name: np.asarray(q) / UR5.joint_to_boundary for name, q in records.items()}


def _predicted_rms(records: dict[str, np.ndarray]) -> float:
    m, task, _ = _by_hand(records)
    return float(np.sqrt(np.trace(task @ np.linalg.inv(m))))


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_ballbar_design_with_fixed_records_completes_what_was_measured(client: TestClient, arm: str) -> None:
    """Twelve records already measured (eight against a1, four against a2): the design of 30 more predicts the
    TCP error that the fit of all 42 has, computed by hand; and it completes them better than the design that
    does not know them."""
    deg = UR5.joint_to_boundary
    measured = sample_workspace(UR5, 12, seed=900) * deg
    fixed = [{"joints": q.tolist(), "anchor": "a1" if i < 8 else "a2"} for i, q in enumerate(measured)]
    body = _ballbar(count=30, criterion="I", noise=NOISE)
    report = _design(client, arm, {**body, "fixed": fixed})
    assert report["fixed"] == 12 and report["count"] == 30
    chosen = [body["candidates"][i] for i in report["indices"]]
    assert [c["anchor"] for c in chosen] == report["references"]
    m, _, estimated = _by_hand(_campaign(fixed, chosen))
    assert report["identifiable"] == estimated
    assert report["metrics"]["predicted_rms_tcp_mm"] == pytest.approx(
        _predicted_rms(_campaign(fixed, chosen)), rel=1e-6
    )
    assert report["metrics"]["log_det"] == pytest.approx(np.linalg.slogdet(m)[1], rel=1e-6)
    blind = _design(client, arm, body)  # the same design without the fixed records
    unaware = _predicted_rms(_campaign(fixed, [body["candidates"][i] for i in blind["indices"]]))
    assert report["metrics"]["predicted_rms_tcp_mm"] < unaware


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_branch_and_bound_tightens_a_ballbar_designs_bound(client: TestClient, arm: str) -> None:
    body = _ballbar(count=30, criterion="D", noise=NOISE)
    plain = _design(client, arm, body)
    report = _design(client, arm, {**body, "bound_seconds": 1.0})
    branched = report["bound"]["branch_and_bound"]
    assert plain["bound"]["branch_and_bound"] is None and branched is not None and branched["nodes"] > 0
    # Not looser than the relaxation's bound, and no K-subset above it: the design's log det by hand is under it.
    assert report["bound"]["utility"] <= branched["root_utility"] == pytest.approx(plain["bound"]["utility"])
    chosen = [body["candidates"][i] for i in report["indices"]]
    log_det = float(np.linalg.slogdet(_by_hand(_campaign(chosen))[0])[1])
    assert report["bound"]["utility"] - log_det >= -1e-9
    assert branched["root_efficiency"] <= report["efficiency"] <= 1.0


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_min_spread_keeps_the_chosen_ballbar_poses_apart_and_from_the_fixed_ones(client: TestClient, arm: str) -> None:
    spread = 0.2
    measured = sample_workspace(UR5, 4, seed=901) * UR5.joint_to_boundary
    fixed = [{"joints": q.tolist(), "anchor": "a3"} for q in measured]
    body = _ballbar(count=30, criterion="I", noise=NOISE, fixed=fixed)
    report = _design(client, arm, {**body, "min_spread": spread})
    width = (np.asarray(UR5.joint_max) - np.asarray(UR5.joint_min)) * UR5.joint_to_boundary

    def distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:  # RMS over joints of the difference / range
        return np.asarray(np.sqrt(np.mean(((a[:, None, :] - b[None, :, :]) / width) ** 2, axis=2)))

    poses = np.asarray(report["poses"])
    apart = distances(poses, poses)[np.triu_indices(len(poses), 1)]
    assert apart.min() >= spread and distances(poses, measured).min() >= spread
    unconstrained = np.asarray(_design(client, arm, body)["poses"])
    assert distances(unconstrained, unconstrained)[np.triu_indices(len(poses), 1)].min() < spread  # it binds


def test_a_target_the_fixed_ballbar_records_reach_needs_no_more(client: TestClient, arm: str) -> None:
    measured = sample_workspace(UR5, 60, seed=902) * UR5.joint_to_boundary
    fixed = [{"joints": q.tolist(), "anchor": NAMES[i % 3]} for i, q in enumerate(measured)]
    goal = 0.05
    report = _design(client, arm, _ballbar(count=None, target={"rms_tcp_mm": goal}, noise=NOISE, fixed=fixed))
    by_hand = _predicted_rms(_campaign(fixed))
    assert report["count"] == 0 and report["poses"] == [] and report["references"] == []
    assert report["measurement"] == "distance"
    assert report["fixed_mm"] == pytest.approx(by_hand, rel=1e-6) and by_hand <= goal
