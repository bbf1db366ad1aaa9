"""Robots of several chains over HTTP (issue 47): a tree stored from its branches or from a URDF, its tools'
kinematics against the hand-written numpy model of tests/models/tree_reference.py and a hand-written walk of
the URDF, and its calibration through the API: the simulated dual-arm torso and the arm with a two-axis
positioner, perturbed with known truth, measured with noise, their held-out error per tool within 1.1x of an
independent scipy least-squares fit on the numpy model, their relative accuracy reported and within 2x of the
relative error measured against the truth. Every refusal a 4xx naming its field."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from iwr_client.errors import ApiError
from models.description.examples import UR5_DH
from models.tree import RobotTree, ToolRecords, measure_tree, tree_joint_samples
from models.tree.examples import arm_with_positioner, dual_arm_torso
from tests.models.test_tree_identification import simulated_campaign
from tests.models.test_tree_urdf import TIPS, URDF, _urdf_fk
from tests.models.tree_reference import POSITIONER as POSITIONER_SEGMENTS
from tests.models.tree_reference import (
    TORSO,
    Segment,
    chain_fk,
    reference_fit,
    relative,
    rms_error,
    tool_positions,
)
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


# ---------------------------------------------------------------------------------------------- the resource
@pytest.mark.slow  # its audit and list reads, the app's first requests: ~0.5 s
def test_a_tree_is_stored_ordered_and_shown_back(api: TestClient) -> None:
    made = api.post("/v1/robot-trees", json=torso_document("torso-crud"))
    assert made.status_code == 201, made.text
    tree = made.json()
    assert made.headers["ETag"] == '"1"'
    assert [(b["name"], b["parent"], b["children"]) for b in tree["branches"]] == [
        ("waist", None, ["left", "right"]),
        ("left", "waist", []),
        ("right", "waist", []),
    ]
    assert tree["tools"] == ["left", "right"] and tree["source"] == "document"
    models_tree = dual_arm_torso()
    # The API's layout is the models' example's, parameter by parameter (names, groups, nominal values).
    assert [p["name"] for p in tree["parameters"]] == list(models_tree.parameters.names)
    np.testing.assert_allclose(to_internal(tree), models_tree.parameters.nominal, atol=1e-12)
    assert tree["joint_names"] == list(models_tree.joint_names) and set(tree["joint_units"]) == {"deg"}
    assert tree["groups"]["waist"] == ["waist.link1.theta", "waist.link1.d", "waist.link1.a", "waist.link1.alpha"]
    assert tree["branches"][1]["joint_ranges"][0] == pytest.approx(list(UR5_DH[0]["range"]))
    assert tree["branches"][0]["links"] == 1 and tree["calibration_id"] is None
    got = api.get(f"/v1/robot-trees/{tree['id']}")
    assert got.json() == tree and got.headers["ETag"] == '"1"'
    assert tree["id"] in [t["id"] for t in api.get("/v1/robot-trees").json()]
    assert api.delete(f"/v1/robot-trees/{tree['id']}", headers={"If-Match": '"7"'}).status_code == 412
    assert api.delete(f"/v1/robot-trees/{tree['id']}", headers={"If-Match": '"1"'}).status_code == 204
    assert api.get(f"/v1/robot-trees/{tree['id']}").status_code == 404
    actions = [e["action"] for e in api.get("/v1/audit", params={"robot_id": tree["id"]}).json()]
    assert actions == ["tree.created", "tree.deleted"]


@pytest.mark.slow  # the torso's two chains and their frames' Functions: ~0.3 s
def test_kinematics_equal_the_hand_written_numpy_model(api: TestClient) -> None:
    tree = create_tree(api, torso_document("torso-fk"))
    models_tree = dual_arm_torso()
    q = tree_joint_samples(models_tree, 4, seed=3)
    answer = api.post(f"/v1/robot-trees/{tree['id']}/kinematics", json={"joints": by_name(models_tree, q)})
    assert answer.status_code == 200, answer.text
    poses = answer.json()["poses"]
    theta = models_tree.parameters.nominal
    reference = {tip: chain_fk(TORSO[tip], theta, q) for tip in ("left", "right")}
    for n, found in enumerate(poses):
        for tip in ("left", "right"):
            got = found["tools"][tip]
            np.testing.assert_allclose(got["position"], reference[tip][n, :3, 3], atol=1e-9)
            w, x, y, z = got["orientation"]
            np.testing.assert_allclose(
                Rotation.from_quat([x, y, z, w]).as_matrix(), reference[tip][n, :3, :3], atol=1e-9
            )
            rv = Rotation.from_matrix(reference[tip][n, :3, :3]).as_rotvec(degrees=True)
            np.testing.assert_allclose(got["rotation_vector_deg"], rv, atol=1e-7)
        for a, b in (("left", "right"), ("right", "left")):
            expected = relative(reference[a][n : n + 1], reference[b][n : n + 1])[0]
            np.testing.assert_allclose(found["relative"][f"{a}/{b}"]["position"], expected[:3, 3], atol=1e-9)
        frames = {f["name"]: f for f in found["frames"]}
        # The waist's frames once, shared by both chains; each chain's last frame is its tool.
        assert sum(name.startswith("waist.") for name in frames) == 2
        assert found["chains"]["left"][:4] == ["base", "waist.link1.mid", "waist.link1", "left.mount"]
        for tip in ("left", "right"):
            assert found["chains"][tip][-1] == f"{tip}.tool"
            np.testing.assert_allclose(frames[f"{tip}.tool"]["position"], reference[tip][n, :3, 3], atol=1e-9)
        # The left mount: the waist's end frame composed with the mount (hand-written: base, waist DH, mount).
        mount = chain_fk(TORSO["left"][:3], theta, q[n : n + 1])[0]
        np.testing.assert_allclose(frames["left.mount"]["position"], mount[:3, 3], atol=1e-9)
        assert frames["left.mount"]["branch"] == "left" and frames["base"]["branch"] is None
    # The same joints as vectors in the tree's order, without frames.
    as_list = api.post(
        f"/v1/robot-trees/{tree['id']}/kinematics", json={"joints": np.degrees(q).tolist(), "frames": False}
    ).json()
    assert as_list["poses"][0]["tools"] == poses[0]["tools"] and as_list["poses"][0]["frames"] is None


@pytest.mark.slow  # the URDF read and two 7R chains: ~0.8 s
def test_a_urdf_tree_has_the_urdfs_forward_kinematics(api: TestClient) -> None:
    made = api.post("/v1/robot-trees", json={"name": "yumi", "urdf": URDF, "base_link": "world", "tip_links": TIPS})
    assert made.status_code == 201, made.text
    tree = made.json()
    assert tree["source"] == "urdf" and tree["tip_links"] == TIPS
    assert [(b["name"], b["parent"]) for b in tree["branches"]] == [
        ("body", None),
        ("gripper_l", "body"),
        ("gripper_r", "body"),
    ]
    assert tree["joint_names"][:2] == ["waist_joint", "joint_1_l"]
    rng = np.random.default_rng(5)
    lo, hi = (
        np.array([b["joint_ranges"][k][i] for b in tree["branches"] for k in range(len(b["joint_ranges"]))])
        for i in (0, 1)
    )
    q = rng.uniform(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), size=(3, lo.size))  # degrees
    joints = [dict(zip(tree["joint_names"], row.tolist(), strict=True)) for row in q]
    poses = api.post(f"/v1/robot-trees/{tree['id']}/kinematics", json={"joints": joints}).json()["poses"]
    for n, found in enumerate(poses):
        for tip in TIPS:
            walk = _urdf_fk(URDF, tip, {k: np.radians(v) for k, v in joints[n].items()})
            np.testing.assert_allclose(found["tools"][tip]["position"], walk[:3, 3], atol=1e-8)


# ---------------------------------------------------------------------------------------------- refusals
def _refused(api: TestClient, path: str, body: dict[str, Any], status: int = 422) -> dict[str, Any]:
    answer = api.post(path, json=body)
    assert answer.status_code == status, answer.text
    problem: dict[str, Any] = answer.json()
    return problem


def test_bad_trees_are_refused_naming_the_field(api: TestClient) -> None:
    def branches(**change: Any) -> dict[str, Any]:
        doc = torso_document("bad")
        for index, fields in change.items():
            doc["branches"][int(index[1:])].update(fields)
        return doc

    cases = [
        (branches(b0={"parent": "hip"}), "branches[0].parent", "no branch of the tree"),
        (branches(b1={"parent": "left"}), "branches[0].parent", "cycle"),
        (branches(b2={"name": "left"}), "branches[2].name", "both named 'left'"),
        (branches(b2={"tool": None}), "branches[2].tool", "has no tool"),
        (branches(b2={"joint_names": ["waist.q1", "a", "b", "c", "d", "e"]}), "branches[2].joint_names", "both"),
        (branches(b1={"stages": [{"kind": "serial", "convention": "dh", "links": [{"joint": "revolute", "a": 1}]}]}),
         "branches[1].stages[0].links[0].range", "range"),
    ]  # fmt: skip
    for body, field, words in cases:
        problem = _refused(api, "/v1/robot-trees", body)
        assert problem["field"] == field, problem
        assert words in problem["detail"], problem
    many = {"kind": "serial", "convention": "dh", "links": [dict(UR5_DH[0])] * 50}
    doc = torso_document("big")
    for branch in doc["branches"]:
        branch["stages"] = [many]
    problem = _refused(api, "/v1/robot-trees", doc)
    assert "more than 128 links" in problem["detail"] or "joints" in problem["detail"], problem
    xacro = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><xacro:arm/></robot>'
    problem = _refused(api, "/v1/robot-trees", {"name": "x", "urdf": xacro, "base_link": "a", "tip_links": ["b"]})
    assert "xacro" in problem["detail"] and problem["field"] == "urdf"
    problem = _refused(api, "/v1/robot-trees", {"name": "u", "urdf": URDF, "base_link": "world", "tip_links": ["hand"]})
    assert problem["field"] == "tip_links[0]"
    assert api.get("/v1/robot-trees").json() == [t for t in api.get("/v1/robot-trees").json() if t["name"] != "bad"]


@pytest.mark.slow  # a refused fit of eight records runs the identifiability analysis: ~0.4 s
def test_bad_records_and_joints_are_refused_naming_them(api: TestClient) -> None:
    tree = create_tree(api, positioner_document("refusals"))
    models_tree = arm_with_positioner()
    joints = by_name(models_tree, tree_joint_samples(models_tree, 1, seed=1))[0]
    record = {"tool": "arm", "joints": joints, "position": [1000.0, 0.0, 500.0]}
    path = f"/v1/robot-trees/{tree['id']}/calibrations"
    problem = _refused(api, path, {"records": [record, {**record, "tool": "torch"}]})
    assert problem["field"] == "records[1].tool" and problem["allowed"] == ["arm", "positioner"]
    problem = _refused(api, path, {"records": [{**record, "frame": "table"}]})
    assert problem["field"] == "records[0].frame"
    partial = {k: v for k, v in joints.items() if k != "positioner.q2"}
    problem = _refused(api, path, {"records": [record, {**record, "joints": partial}]})
    assert problem["field"] == "records[1].joints" and "['positioner.q2'] are missing" in problem["detail"]
    problem = _refused(api, path, {"records": [{**record, "joints": {**joints, "elbow": 3.0}}]})
    assert "no joint 'elbow'" in problem["detail"]
    # Eight position records, 24 equations, cannot determine the 25 parameters of the arm they see (and leave one
    # for the noise): the count named.
    spread = np.random.default_rng(3).uniform(-800, 800, size=(8, 3)).tolist()  # not on a line: registrable
    eight = [
        {**record, "joints": j, "position": p}
        for j, p in zip(by_name(models_tree, tree_joint_samples(models_tree, 8, seed=2)), spread, strict=True)
    ]
    problem = _refused(api, path, {"records": eight})
    assert problem["type"].endswith("too-few-measurements") and problem["detail"].startswith("records: 24 equations")
    assert problem["needed"] > problem["got"] == 24
    stale = api.post(path, json={"records": eight}, headers={"If-Match": '"9"'})
    assert stale.status_code == 412
    # Admitted by its estimated cost: 500 records of the 56-parameter cell are over the 2 s synchronous budget.
    problem = _refused(api, path, {"records": [record] * 500})
    assert problem["type"].endswith("work-too-large") and problem["limit_s"] == 2.0
    assert "tree calibration of 500 records over 56 parameters" in problem["detail"]
    problem = _refused(api, f"/v1/robot-trees/{tree['id']}/kinematics", {"joints": [partial]})
    assert problem["field"] == "joints[0]"
    assert api.get(f"{path}").json() == []  # nothing stored by any refusal
    assert api.get(f"/v1/robot-trees/{tree['id']}").json()["revision"] == 1


# ---------------------------------------------------------------------------------------------- calibration
def _kabsch(model: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R, t minimising |R model + t - measured| (SVD, written here)."""
    cm, cs = model.mean(axis=0), measured.mean(axis=0)
    u, _, vt = np.linalg.svd((model - cm).T @ (measured - cs))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, cs - r @ cm


def _registered_fit(
    segments: dict[str, list[Segment]], groups: list[ToolRecords], nominal: np.ndarray, free: np.ndarray,
    scales: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """The scipy reference fit over the parameters the API estimated, from the nominal with the base registered by
    this test's own Kabsch fit: the reference's parameters."""
    absolute = [g for g in groups if g.frame is None]
    model = np.vstack([tool_positions(segments, nominal, g.tool, None, g.joints) for g in absolute])
    r, t = _kabsch(model, np.vstack([g.positions for g in absolute]))
    start = nominal.copy()
    start[:6] = np.r_[t, Rotation.from_matrix(r).as_rotvec()]
    return reference_fit(segments, groups, start, free, scales, NOISE.position_mm)


@dataclass(frozen=True)
class Campaign:
    tree: RobotTree
    segments: dict[str, list[Segment]]
    pair: tuple[str, str]
    truth: np.ndarray
    answer: dict[str, Any]
    """The API's calibration."""
    calibrated: np.ndarray
    """The tree's parameters GET shows after it (internal units)."""
    reference: np.ndarray
    test_joints: np.ndarray
    before: dict[str, Any]
    after: dict[str, Any]


def _campaign(api: TestClient, doc: dict[str, Any], make: Callable[[], RobotTree], segments: dict[str, list[Segment]],
              pair: tuple[str, str], poses: int) -> Campaign:  # fmt: skip
    tree = make()
    made = create_tree(api, doc)
    sim, groups = simulated_campaign(tree, pair, poses)
    held_q = tree_joint_samples(tree, 15, seed=13)
    held = [measure_tree(sim, tip, held_q, noise=NOISE, seed=20 + k) for k, tip in enumerate(tree.tips)]
    body = {
        "records": record_docs(groups, tree),
        "held_out": record_docs(held, tree),
        "noise_position_mm": NOISE.position_mm,
    }
    answer = calibrate_tree(api, made["id"], body, headers={"If-Match": '"1"'})
    after = api.get(f"/v1/robot-trees/{made['id']}").json()
    names = tree.parameters.index
    free = np.array([names[n] for n in answer["estimated"]])
    reference = _registered_fit(segments, groups, tree.parameters.nominal, free, tree.parameters.scales)
    return Campaign(
        tree, segments, pair, sim.truth, answer, to_internal(after), reference,
        tree_joint_samples(tree, 100, seed=99), made, after,
    )  # fmt: skip


@pytest.fixture(scope="module")
def torso(api: TestClient) -> Campaign:
    return _campaign(api, torso_document("torso-cal"), dual_arm_torso, TORSO, ("left", "right"), 24)


@pytest.fixture(scope="module")
def positioner(api: TestClient) -> Campaign:
    return _campaign(api, positioner_document("positioner-cal"), arm_with_positioner, POSITIONER_SEGMENTS,
                     ("arm", "positioner"), 20)  # fmt: skip


def _error(c: Campaign, theta: np.ndarray, tool: str, frame: str | None) -> float:
    """RMS position error over the test joints against the truth, on the numpy model."""
    return rms_error(c.segments, theta, c.truth, c.test_joints, tool, frame)


@pytest.mark.slow  # two calibrations through the API and two finite-difference reference fits: ~6 s of CPU
@pytest.mark.parametrize("which", ["torso", "positioner"])
def test_held_out_error_of_each_tool_is_within_a_tenth_of_a_scipy_reference(
    which: str, request: pytest.FixtureRequest
) -> None:
    c: Campaign = request.getfixturevalue(which)
    assert c.answer["applied"] and c.answer["revision"] == 2 and c.after["revision"] == 2
    assert c.after["calibration_id"] == c.answer["id"]
    assert c.answer["noise_consistent"], c.answer["variance_factor"]
    for tool in c.tree.tips:
        ours, theirs = _error(c, c.calibrated, tool, None), _error(c, c.reference, tool, None)
        assert ours <= 1.1 * theirs, (tool, ours, theirs)
        assert ours < _error(c, c.tree.parameters.nominal, tool, None) / 100  # the instrument's frame included
    # The answer's parameters are the ones stored, with their σ.
    np.testing.assert_allclose(to_internal({"parameters": c.answer["parameters"]}), c.calibrated, atol=1e-9)
    assert all(p["std_error"] is not None for p in c.after["parameters"] if p["name"] in c.answer["estimated"])


@pytest.mark.slow  # shares the calibrations above
@pytest.mark.parametrize("which", ["torso", "positioner"])
def test_relative_accuracy_is_reported_and_is_the_size_of_the_measured_relative_error(
    which: str, request: pytest.FixtureRequest
) -> None:
    c: Campaign = request.getfixturevalue(which)
    predicted = {a["label"]: a for a in c.answer["accuracy"]}
    a, b = c.pair
    assert set(predicted) == {a, b, f"{a}/{b}"}
    assert predicted[f"{a}/{b}"]["tool"] == a and predicted[f"{a}/{b}"]["frame"] == b
    for label, (tool, frame) in {a: (a, None), b: (b, None), f"{a}/{b}": (a, b)}.items():
        measured = _error(c, c.calibrated, tool, frame)
        assert 0.5 < measured / predicted[label]["rms_position_mm"] < 2.0, (label, measured, predicted[label])


@pytest.mark.slow  # shares the calibrations above
@pytest.mark.parametrize("which", ["torso", "positioner"])
def test_the_reported_fit_and_held_out_errors_are_the_records_own(
    which: str, request: pytest.FixtureRequest, api: TestClient
) -> None:
    c: Campaign = request.getfixturevalue(which)
    fit = {e["label"]: e for e in c.answer["fit"]}
    held = {e["label"]: e for e in c.answer["held_out"]}
    a, b = c.pair
    assert set(fit) == {a, b, f"{a}/{b}"} and set(held) == {a, b}
    for tool in (a, b):
        assert held[tool]["records"] == 15
        # The held-out records' error is the noise and the fit's own (a few hundredths of a mm): before the fit
        # the geometric errors were tenths to mm.
        assert held[tool]["rms_mm"] < 3 * NOISE.position_mm * np.sqrt(3)
        assert held[tool]["before_rms_mm"] > 10 * held[tool]["rms_mm"]
        assert fit[tool]["rms_mm"] == pytest.approx(NOISE.position_mm * np.sqrt(3), rel=0.35)
    listed = api.get(f"/v1/robot-trees/{c.before['id']}/calibrations").json()
    assert [x["id"] for x in listed] == [c.answer["id"]]
    assert api.get(f"/v1/robot-trees/{c.before['id']}/calibrations/{c.answer['id']}").json() == c.answer


def test_the_python_client_makes_reads_and_deletes_a_tree(api: TestClient) -> None:
    client = InProcess(api)
    doc = positioner_document("by-client")
    made = client.create_robot_tree(doc["name"], doc["branches"])
    assert made["tools"] == ["arm", "positioner"]
    assert client.robot_tree(made["id"]) == made
    assert made["id"] in [t["id"] for t in client.robot_trees()]
    models_tree = arm_with_positioner()
    q = tree_joint_samples(models_tree, 2, seed=8)
    found = client.tree_kinematics(made["id"], np.degrees(q).tolist())
    reference = chain_fk(POSITIONER_SEGMENTS["arm"], models_tree.parameters.nominal, q)
    np.testing.assert_allclose([p["tools"]["arm"]["position"] for p in found["poses"]], reference[:, :3, 3], atol=1e-9)
    assert found["poses"][0]["frames"] is None
    assert client.tree_calibrations(made["id"]) == []
    with pytest.raises(ApiError) as refused:
        client.calibrate_tree(made["id"], [{"tool": "torch", "joints": [0.0] * 8, "position": [0.0, 0.0, 0.0]}])
    assert refused.value.problem["field"] == "records[0].tool"
    client.delete_robot_tree(made["id"], if_match='"1"')
    assert made["id"] not in [t["id"] for t in client.robot_trees()]
