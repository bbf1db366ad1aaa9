"""What a robot of several chains is calibrated for, over HTTP (issue 47): a record design over the tree whose
records, simulated on a perturbed truth and calibrated through the API, judge better on held-out records than as
many random records; compensated joints that put the tool on world and relative targets on the TRUE tree (the
hand-written numpy model of tests/models/tree_reference.py) after a calibration through the API; the calibrated
URDF tree read back by the models' importer and the per-branch DH tables composed by hand, both equal to the
calibrated tree's kinematics; every refusal a 4xx naming its field."""

from __future__ import annotations

import csv
import io
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from models.compensation.poses import pose_matrices
from models.noise import NoiseModel
from models.tree import (
    RobotTree,
    measure_tree,
    perturbed_tree,
    relative_poses,
    tool_poses,
    tree_from_urdf,
    tree_joint_samples,
)
from models.tree.examples import arm_with_positioner, dual_arm_torso
from tests.models.test_tree_compensation import _away_from_singularities
from tests.models.test_tree_urdf import TIPS, URDF
from tests.models.tree_reference import POSITIONER, chain_fk, relative
from tests.service.helpers import InProcess
from tests.service.trees import (
    NOISE,
    by_name,
    calibrate_tree,
    create_tree,
    positioner_document,
    record_docs,
    to_internal,
    torso_document,
)


def _joints(tree: RobotTree, records: list[dict[str, Any]]) -> np.ndarray:
    """The API's joints by name (deg: every joint of these trees is revolute) as internal joint vectors."""
    return np.radians([[r["joints"][n] for n in tree.joint_names] for r in records])


# ---------------------------------------------------------------------------------------------- designs
COUNT = 24


@pytest.mark.slow  # a design and two calibrations through the API: ~3 s of CPU
def test_designed_records_predict_and_calibrate_better_than_as_many_random_ones(api: TestClient) -> None:
    tree = arm_with_positioner()
    made = create_tree(api, positioner_document("design-cell"))
    body = {"count": COUNT, "criterion": "D", "candidate_count": 150, "seed": 3, "noise_position_mm": 0.02}
    answer = api.post(f"/v1/robot-trees/{made['id']}/designs", json=body)
    assert answer.status_code == 200, answer.text
    design = answer.json()
    assert design["count"] == COUNT and len(design["records"]) == COUNT and design["candidates"] == 300
    assert {r["tool"] for r in design["records"]} == {"arm", "positioner"}
    assert design["value"] > design["random_baseline"]["value"]  # log det
    ours = {a["label"]: a["rms_position_mm"] for a in design["accuracy"]}
    theirs = {a["label"]: a["rms_position_mm"] for a in design["random_accuracy"]}
    assert set(ours) == {"arm", "positioner", "arm/positioner"}
    for label, rms in ours.items():
        assert rms < theirs[label], (label, ours, theirs)

    # The records it names, measured on a perturbed truth, against as many random records of the same tools.
    sim = perturbed_tree(tree, seed=31)
    designed = _joints(tree, design["records"])
    rng_q = tree_joint_samples(tree, COUNT, seed=32)
    held_q = tree_joint_samples(tree, 40, seed=33)
    held = [measure_tree(sim, tip, held_q, noise=NoiseModel(position_mm=0.002), seed=40 + k) for k, tip in
            enumerate(tree.tips)]  # fmt: skip

    def calibrated(q: np.ndarray, seed: int) -> dict[str, float]:
        groups = []
        for k, tip in enumerate(tree.tips):
            rows = [i for i, r in enumerate(design["records"]) if r["tool"] == tip]
            groups.append(measure_tree(sim, tip, q[rows], noise=NOISE, seed=seed + k))
        body = {"records": record_docs(groups, tree), "held_out": record_docs(held, tree), "noise_position_mm": 0.02,
                "apply": False, "accuracy_samples": 10}  # fmt: skip
        fit = calibrate_tree(api, made["id"], body)
        return {e["label"]: e["rms_mm"] for e in fit["held_out"]}

    by_design, by_chance = calibrated(designed, 50), calibrated(rng_q, 50)
    for tip in tree.tips:
        assert by_design[tip] < 0.8 * by_chance[tip], (tip, by_design, by_chance)


@pytest.mark.slow  # one small design, twice (JSON, CSV): ~0.6 s of CPU
def test_a_design_of_pose_and_relative_records_within_sub_ranges_and_its_csv(api: TestClient) -> None:
    tree = arm_with_positioner()
    made = create_tree(api, positioner_document("design-kinds"))
    body = {
        "count": 12,
        "criterion": "I",
        "measure": [{"tool": "arm", "frame": "positioner", "measurement": "pose"}, {"tool": "positioner"}],
        "candidate_count": 40,
        "joint_ranges": {"positioner.q1": [-20, 30], "arm.q2": [-120, -60]},
        "seed": 5,
    }
    design = api.post(f"/v1/robot-trees/{made['id']}/designs", json=body).json()
    assert design["candidates"] == 80 and design["criterion"] == "I"
    kinds = {(r["tool"], r["frame"], r["measurement"]) for r in design["records"]}
    assert kinds <= {("arm", "positioner", "pose"), ("positioner", None, "position")}
    for r in design["records"]:
        assert -20 <= r["joints"]["positioner.q1"] <= 30 and -120 <= r["joints"]["arm.q2"] <= -60
    assert [a["label"] for a in design["accuracy"]] == ["arm", "positioner", "arm/positioner"]
    sheet = api.post(f"/v1/robot-trees/{made['id']}/designs", json=body, headers={"Accept": "text/csv"})
    assert sheet.headers["content-type"].startswith("text/csv")
    rows = list(csv.reader(io.StringIO(sheet.text)))
    assert rows[0] == ["tool", "frame", "measurement", *tree.joint_names]
    assert len(rows) == 13
    for row, record in zip(rows[1:], design["records"], strict=True):
        assert row[:3] == [record["tool"], record["frame"] or "", record["measurement"]]
        assert [float(v) for v in row[3:]] == [record["joints"][n] for n in tree.joint_names]


# ---------------------------------------------------------------------------------------------- compensation
@dataclass(frozen=True)
class Calibrated:
    tree: RobotTree
    id: str
    truth: np.ndarray
    calibrated: np.ndarray
    calibration_id: str


@pytest.fixture(scope="module")
def calibrated_cell(api: TestClient) -> Calibrated:
    """The arm and positioner cell calibrated through the API from pose records of both tools on a perturbed
    simulated truth, with a fine instrument (1 µm, 0.0005°): the compensation is then judged by its own error,
    not by the calibration's."""
    tree = arm_with_positioner()
    made = create_tree(api, positioner_document("compensated-cell"))
    sim = perturbed_tree(tree, seed=61, tolerances=1.5)  # errors that a program misses by > 0.5 mm
    fine = NoiseModel(position_mm=0.001, orientation_rad=np.radians(0.0005))
    q = tree_joint_samples(tree, 30, seed=62)
    groups = [measure_tree(sim, tip, q, noise=fine, seed=63 + k, position_only=False) for k, tip in
              enumerate(tree.tips)]  # fmt: skip
    body = {"records": record_docs(groups, tree), "noise_position_mm": 0.001, "noise_orientation_deg": 0.0005,
            "accuracy_samples": 10}  # fmt: skip
    fit = calibrate_tree(api, made["id"], body)
    after = api.get(f"/v1/robot-trees/{made['id']}").json()
    return Calibrated(tree, made["id"], sim.truth, to_internal(after), fit["id"])


def _pose_doc(t: np.ndarray) -> dict[str, list[float]]:
    x, y, z, w = Rotation.from_matrix(t[:3, :3]).as_quat()
    return {"position": t[:3, 3].tolist(), "orientation": [float(w), float(x), float(y), float(z)]}


@pytest.mark.slow  # a calibration through the API and two compensations: ~2 s of CPU
def test_compensated_joints_reach_world_and_relative_targets_on_the_true_tree(
    api: TestClient, calibrated_cell: Calibrated
) -> None:
    c = calibrated_cell
    tree = c.tree
    q = _away_from_singularities(tree, "arm")
    # The program: taught on the nominal cell. Relative targets (the torch in the part frame) need no placing;
    # world targets are in the instrument's frame, the nominal cell placed where the calibration put it.
    taught_rel = relative_poses(tree, "arm", "positioner", q)
    placed = tree.parameters.nominal.copy()
    placed[:6] = c.calibrated[:6]
    taught_world = tool_poses(tree, "arm", q, placed)
    rel_targets = pose_matrices(taught_rel.positions, taught_rel.rotations)
    world_targets = pose_matrices(taught_world.positions, taught_world.rotations)
    joints = by_name(tree, q)
    targets = [{"tool": "arm", "frame": "positioner", "joints": j, **_pose_doc(t)} for j, t in
               zip(joints, rel_targets, strict=True)]  # fmt: skip
    targets += [{"tool": "arm", "joints": j, **_pose_doc(t)} for j, t in zip(joints, world_targets, strict=True)]
    answer = api.post(f"/v1/robot-trees/{c.id}/compensations", json={"targets": targets})
    assert answer.status_code == 200, answer.text
    found = answer.json()
    assert found["calibration_id"] == c.calibration_id and found["revision"] == 2
    assert found["reached"] == len(targets), [t["reason"] for t in found["targets"]]
    n = q.shape[0]
    solved = _joints(tree, found["targets"])
    assert all(t["moved"] == [f"arm.q{k}" for k in range(1, 7)] for t in found["targets"])
    np.testing.assert_allclose(solved[:, 6:], np.vstack([q, q])[:, 6:], atol=1e-12)  # the positioner: as programmed

    def true_rel(j: np.ndarray) -> np.ndarray:
        return relative(chain_fk(POSITIONER["arm"], c.truth, j), chain_fk(POSITIONER["positioner"], c.truth, j))

    def miss(reached: np.ndarray, goal: np.ndarray) -> np.ndarray:
        return np.asarray(np.linalg.norm(reached[:, :3, 3] - goal[:, :3, 3], axis=1))

    # On the TRUE tree (the numpy model): the program misses every target, the compensated joints reach them.
    assert miss(true_rel(q), rel_targets).min() > 0.5
    assert miss(true_rel(solved[:n]), rel_targets).max() < 0.01
    # World targets: the true base is the instrument's, which the calibration found (within its own error).
    assert miss(chain_fk(POSITIONER["arm"], c.truth, q), world_targets).min() > 0.5
    assert miss(chain_fk(POSITIONER["arm"], c.truth, solved[n:]), world_targets).max() < 0.01
    change = found["targets"][0]["change"]
    assert set(change) == {f"arm.q{k}" for k in range(1, 7)}
    assert max(abs(v) for v in change.values()) < 5.0  # deg: a correction, the program's configuration


@pytest.mark.slow  # Newton on the narrowed arm's chain: ~0.3 s
def test_a_target_past_a_joints_range_is_refused_with_its_reason(api: TestClient) -> None:
    doc = positioner_document("narrow-cell")
    doc["branches"][0]["stages"][0]["links"][1]["range"] = [-170.0, 170.0]
    made = create_tree(api, doc)
    tree = arm_with_positioner()
    q = tree_joint_samples(tree, 2, seed=4, margin=0.1)
    q[:, 1] = np.radians(169.8)
    past = q.copy()
    past[:, 1] = np.radians(170.4)
    at = tool_poses(tree, "arm", past, check_ranges=False)
    targets = [{"tool": "arm", "joints": j, **_pose_doc(t)} for j, t in
               zip(by_name(tree, q), pose_matrices(at.positions, at.rotations), strict=True)]  # fmt: skip
    found = api.post(f"/v1/robot-trees/{made['id']}/compensations", json={"targets": targets}).json()
    assert found["reached"] == 0 and found["calibration_id"] is None
    for t in found["targets"]:
        assert not t["reached"] and "out of range" in t["reason"] and "arm.q2" in t["reason"], t["reason"]
        assert t["joints"] == targets[0]["joints"] or t["joints"] == targets[1]["joints"]  # as the program gave


# ---------------------------------------------------------------------------------------------- exports
def _calibrate_on_a_perturbed_truth(api: TestClient, tree_id: str, tree: RobotTree, *, seed: int, poses: int) -> None:
    """`tree` perturbed (`seed`), every tool's position measured at `poses` random joint vectors, and the API's
    tree `tree_id` calibrated from them (applied: its revision 2)."""
    sim = perturbed_tree(tree, seed=seed)
    q = tree_joint_samples(tree, poses, seed=seed + 1)
    groups = [measure_tree(sim, tip, q, noise=NOISE, seed=seed + 2 + k) for k, tip in enumerate(tree.tips)]
    body = {"records": record_docs(groups, tree), "noise_position_mm": 0.02, "accuracy_samples": 10}
    calibrate_tree(api, tree_id, body)


@pytest.fixture(scope="module")
def calibrated_urdf(api: TestClient) -> tuple[dict[str, Any], RobotTree]:
    """The URDF dual-arm tree calibrated through the API from positions of both hands on a perturbed truth."""
    tree = tree_from_urdf(URDF, "world", TIPS, name="yumi-export")
    made = create_tree(api, {"name": "yumi-export", "urdf": URDF, "base_link": "world", "tip_links": TIPS})
    _calibrate_on_a_perturbed_truth(api, made["id"], tree, seed=71, poses=30)
    return api.get(f"/v1/robot-trees/{made['id']}").json(), tree


def _frame(f: dict[str, float]) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_euler("xyz", [f["roll_deg"], f["pitch_deg"], f["yaw_deg"]], degrees=True).as_matrix()
    t[:3, 3] = [f["x_mm"], f["y_mm"], f["z_mm"]]
    return t


@pytest.mark.slow  # a calibration of the 15-joint URDF tree through the API and the URDF read back: ~2 s
def test_the_exported_urdf_read_back_has_the_calibrated_trees_kinematics(
    api: TestClient, calibrated_urdf: tuple[dict[str, Any], RobotTree]
) -> None:
    after, tree = calibrated_urdf
    assert after["revision"] == 2
    exported = api.get(f"/v1/robot-trees/{after['id']}/exports/urdf?format=json")
    assert exported.status_code == 200, exported.text
    sidecar = exported.json()
    xml = api.get(f"/v1/robot-trees/{after['id']}/exports/urdf")
    assert xml.headers["content-type"].startswith("application/xml") and xml.text == sidecar["urdf"]
    assert "world_from_base_link" in xml.text and f"tip_to_tcp[{TIPS[0]}]" in xml.text
    # A drop-in: every link and joint of the imported document, under its name.
    names = {(e.tag, e.get("name")) for e in ET.fromstring(URDF)}
    assert {(e.tag, e.get("name")) for e in ET.fromstring(xml.text)} == names
    read = tree_from_urdf(xml.text, "world", TIPS, name="read-back")
    q = tree_joint_samples(tree, 20, seed=74)
    theta = to_internal(after)
    world = _frame(sidecar["world_from_base_link"])
    for tip in TIPS:
        expected = tool_poses(tree, tip, q, theta)
        back = tool_poses(read, tip, q)
        got = world @ pose_matrices(back.positions, back.rotations) @ _frame(sidecar["tip_to_tcp"][tip])
        np.testing.assert_allclose(got[:, :3, 3], expected.positions, atol=1e-6)  # mm
        np.testing.assert_allclose(got[:, :3, :3], expected.rotations, atol=1e-9)
    # Against the nominal tree, the calibration moved the tools by tenths of a mm or more: the check has teeth.
    nominal = tool_poses(tree, TIPS[0], q).positions
    assert np.abs(tool_poses(tree, TIPS[0], q, theta).positions - nominal).max() > 0.1


def _dh_link(link: dict[str, Any], q: np.ndarray) -> np.ndarray:
    """(N, 4, 4) a standard DH link, Rz(θ + q) Tz(d) Tx(a) Rx(α), written here."""
    theta = np.radians(link["theta_deg"]) + q
    d, a, alpha = link["d_mm"], link["a_mm"], np.radians(link["alpha_deg"])
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    t = np.zeros((q.size, 4, 4))
    t[:, 0] = np.stack([ct, -st * ca, st * sa, a * ct], axis=1)
    t[:, 1] = np.stack([st, ct * ca, -ct * sa, a * st], axis=1)
    t[:, 2, 1], t[:, 2, 2], t[:, 2, 3], t[:, 3, 3] = sa, ca, d, 1.0
    return t


@pytest.mark.slow  # a calibration of the torso through the API: ~1.5 s
def test_the_dh_tables_composed_by_hand_are_the_calibrated_torsos_kinematics(api: TestClient) -> None:
    tree = dual_arm_torso()
    made = create_tree(api, torso_document("torso-dh"))
    _calibrate_on_a_perturbed_truth(api, made["id"], tree, seed=81, poses=24)
    theta = to_internal(api.get(f"/v1/robot-trees/{made['id']}").json())
    tables = api.get(f"/v1/robot-trees/{made['id']}/exports/dh").json()
    assert tables["revision"] == 2 and tables["left_out"] == []
    by_branch = {b["branch"]: b for b in tables["branches"]}
    assert [b["branch"] for b in tables["branches"]] == ["waist", "left", "right"]
    test_q = tree_joint_samples(tree, 10, seed=84)
    column = {name: j for j, name in enumerate(tree.joint_names)}

    def end(branch: str, at: np.ndarray) -> np.ndarray:
        """The branch's end frame after `at`: its links, each turned by its own joint (the table's q1 … are the
        branch's, `{branch}.q1` … in the tree)."""
        for link in by_branch[branch]["links"]:
            at = at @ _dh_link(link, test_q[:, column[f"{branch}.{link['name']}"]])
        return at

    waist_end = end("waist", np.broadcast_to(_frame(by_branch["waist"]["base"]), (10, 4, 4)))
    for tip in ("left", "right"):
        b = by_branch[tip]
        tcp = end(tip, waist_end @ _frame(b["base"])) @ _frame(b["tool"])
        np.testing.assert_allclose(tcp[:, :3, 3], tool_poses(tree, tip, test_q, theta).positions, atol=1e-6)
    sheet = api.get(f"/v1/robot-trees/{made['id']}/exports/dh", headers={"Accept": "text/csv"})
    rows = list(csv.DictReader(io.StringIO(sheet.text)))
    assert len(rows) == 3 * 2 + 1 + 6 + 6
    left = [r for r in rows if r["branch"] == "left" and r["type"] == "revolute"]
    assert [float(r["a_mm"]) for r in left] == [link["a_mm"] for link in by_branch["left"]["links"]]


# ---------------------------------------------------------------------------------------------- refusals
def _problem(answer: Any, status: int = 422) -> dict[str, Any]:
    assert answer.status_code == status, answer.text
    found: dict[str, Any] = answer.json()
    return found


@pytest.mark.slow  # twenty refusals, the tree's chains built for the joints' checks: ~0.4 s
def test_bad_designs_compensations_and_exports_are_refused_naming_the_field(api: TestClient) -> None:
    made = create_tree(api, positioner_document("refused-ops"))
    tree = arm_with_positioner()
    path = f"/v1/robot-trees/{made['id']}"
    cases = [
        ({"count": 5, "measure": [{"tool": "torch"}]}, "measure[0].tool"),
        ({"count": 5, "measure": [{"tool": "arm", "frame": "arm"}]}, "measure[0].frame"),
        ({"count": 5, "measure": [{"tool": "arm"}, {"tool": "arm"}]}, "measure[1]"),
        ({"count": 50, "candidate_count": 10}, "count"),
        ({"count": 5, "joint_ranges": {"arm.q9": [0, 1]}}, "joint_ranges.arm.q9"),
        ({"count": 5, "joint_ranges": {"positioner.q1": [-100, 0]}}, "joint_ranges.positioner.q1"),
        ({"count": 5, "joint_ranges": {"positioner.q1": [10, 0]}}, "joint_ranges.positioner.q1"),
        ({"count": 5, "candidates": [[0.0] * 7]}, "candidates[0]"),
    ]
    for body, field in cases:
        problem = _problem(api.post(f"{path}/designs", json=body))
        assert problem["field"] == field, (body, problem)
    too_much = {"count": 30, "candidate_count": 3000, "measure": [{"tool": "arm", "measurement": "pose"}]}
    problem = _problem(api.post(f"{path}/designs", json=too_much))
    assert "budget" in problem["detail"] and "send fewer" in problem["detail"], problem
    assert _problem(api.post(f"{path}/designs", json={"count": 0}))["status"] == 422
    assert _problem(api.post("/v1/robot-trees/nope/designs", json={"count": 5}), 404)["status"] == 404

    joints = by_name(tree, tree_joint_samples(tree, 1, seed=1))[0]
    target = {"tool": "arm", "joints": joints, "position": [1000.0, 0.0, 500.0], "orientation": [1.0, 0, 0, 0]}
    wide = dict(joints, **{"positioner.q1": 120.0})
    compensations: list[tuple[dict[str, Any], str | None]] = [
        ({**target, "tool": "torch"}, "targets[0].tool"),
        ({**target, "frame": "welder"}, "targets[0].frame"),
        ({**target, "frame": "arm"}, "targets[0].frame"),
        ({**target, "orientation": [1.0, 1.0, 0, 0]}, None),
    ]
    for body, named in compensations:
        problem = _problem(api.post(f"{path}/compensations", json={"targets": [body]}))
        assert named is None or problem["field"] == named, (body, problem)
        if named is None:
            assert "targets[0].orientation" in problem["detail"], problem
    # A program's joints out of their range: the joint and the target (pose) named, as a calibration's records.
    problem = _problem(api.post(f"{path}/compensations", json={"targets": [target, {**target, "joints": wide}]}))
    assert (problem["joint"], problem["pose"]) == ("positioner.q1", 1), problem
    assert _problem(api.post(f"{path}/compensations", json={"targets": []}))["status"] == 422

    problem = _problem(api.get(f"{path}/exports/urdf"))
    assert problem["field"] == "source" and "no URDF" in problem["detail"], problem
    assert _problem(api.get(f"{path}/exports/dh?format=xml"))["status"] == 422
    assert _problem(api.get(f"{path}/exports/dh", headers={"Accept": "image/png"}), 406)["status"] == 406
    assert _problem(api.get("/v1/robot-trees/nope/exports/dh"), 404)["status"] == 404


@pytest.mark.slow  # a fixture branch's tree and its refusal: ~0.3 s
def test_a_tool_whose_every_joint_carries_another_tool_cannot_be_compensated(api: TestClient) -> None:
    doc = torso_document("torso-fixture")
    doc["branches"].append({"name": "fixture", "parent": "waist", "tool": doc["branches"][0]["tool"]})
    made = create_tree(api, doc)
    names = made["joint_names"]
    target = {"tool": "fixture", "joints": dict.fromkeys(names, 0.0), "position": [0.0, 0.0, 900.0],
              "orientation": [1.0, 0, 0, 0]}  # fmt: skip
    problem = _problem(api.post(f"/v1/robot-trees/{made['id']}/compensations", json={"targets": [target]}))
    assert problem["field"] == "targets[0].tool" and "no joint of its own" in problem["detail"], problem


@pytest.mark.slow  # a small design, a compensation and an export through the client: ~0.8 s
def test_the_python_client_designs_compensates_and_exports(api: TestClient) -> None:
    client = InProcess(api)
    doc = positioner_document("client-ops")
    made = client.create_robot_tree(doc["name"], doc["branches"])
    design = client.design_tree(made["id"], 20, candidate_count=20, seed=2)
    assert design["count"] == 20 and design["candidates"] == 40
    sheet = client.design_tree_csv(made["id"], 20, candidate_count=20, seed=2)
    assert sheet.splitlines()[0].startswith("tool,frame,measurement,arm.q1")
    assert len(sheet.splitlines()) == 21
    tree = arm_with_positioner()
    q = tree_joint_samples(tree, 1, seed=9)
    at = tool_poses(tree, "arm", q)
    target = {"tool": "arm", "joints": by_name(tree, q)[0], **_pose_doc(pose_matrices(at.positions, at.rotations)[0])}
    found = client.compensate_tree(made["id"], [target])
    assert found["reached"] == 1
    # The nominal tree: its own program's joints reach its own targets.
    np.testing.assert_allclose(_joints(tree, found["targets"]), q, atol=1e-7)
    tables = client.tree_export(made["id"], "dh")
    assert [b["branch"] for b in tables["branches"]] == ["arm", "positioner"]
    assert client.tree_export(made["id"], "dh-csv").startswith("branch,row,name")
