"""Issue 45 on a real public campaign: TIAGo (PAL Robotics) read by a Qualisys motion-capture system
(tests/data/real/tiago_mocap/SOURCE.md). The robot is created from its URDF over HTTP (torso_lift_joint, prismatic,
and arm_1 … arm_7 up to arm_tool_link), the training session's 37 postures are sent as one calibration with the
defaults (the hand body's first point as the TCP's tracker records, the other three as reflector records, σ from
each posture's marker_std_mm), and the applied version is judged on the validation session (another day, 62
postures) against an independent fit written here: scipy's least_squares on a numpy forward kinematics of the
URDF's own joint origins, with joint offsets, every moving joint's origin error, the base pose and the four
points' offsets, reduced to the identifiable set by pivoted QR.

The same session's CSV as the publisher ships it, posted as a file (length_unit=m, joint_unit=rad), gives the
same parameters to 1e-9; the protocol's two confirmation sessions (2021-11-30 14:03 and 15:04) 3.293 / 3.293 mm
and 2.776 / 2.776 mm (service / independent).

Measured (2026-12-08): nominal geometry, best rigid fit 71.3 mm RMS on the validation session; the service's
applied calibration 3.468 mm, the independent fit 3.468 mm (ratio 1.0000); predicted for a fresh record in the
measured region 2.71 mm (the model's own 1-σ there 0.84 mm). The publisher's reference (joint offsets only):
4.23 mm."""

from __future__ import annotations

import csv
import hashlib
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from scipy.linalg import qr
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from tests.robot_data import robot_file

DATA = Path(__file__).resolve().parents[1] / "data" / "real" / "tiago_mocap"
TRAINING = "qualisys_2021-11-30_static_postures.csv"
VALIDATION = "qualisys_2021-11-26_static_postures.csv"
CONFIRMATION = ("qualisys_2021-11-30-1403_static_postures.csv", "qualisys_2021-11-30-1504_static_postures.csv")
"""The publisher's protocol's two further sessions (same day as training, earlier): judged as the validation is."""
AS_SHIPPED = {"length_unit": "m", "joint_unit": "rad"}
"""What a file as the publisher ships it needs said: its points and torso in metres, its arm in radians (its
header states no unit); the four points, the joints by the URDF's names and marker_std_mm are read unsaid."""
JOINTS = ("torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8)))
URDF = "tiago_description/robots/tiago_no_hand.urdf"
BASE, TIP = "base_link", "arm_tool_link"
POINTS = 4


@dataclass(frozen=True)
class Session:
    joints: np.ndarray
    """(N, 8) as read: the torso in m, the arm in rad."""
    points: np.ndarray
    """(N, 4, 3) the hand body's four points, mm, in the mocap's base frame."""
    sigma_mm: np.ndarray


def session(name: str) -> Session:
    with (DATA / name).open() as f:
        rows = list(csv.DictReader(f))
    joints = np.array([[float(r[j]) for j in JOINTS] for r in rows])
    points = np.array([[[float(r[f"{a}{k}"]) * 1000.0 for a in "xyz"] for k in range(1, POINTS + 1)] for r in rows])
    return Session(joints, points, np.array([float(r["marker_std_mm"]) for r in rows]))


def records(s: Session, *, reflectors: bool = True) -> list[dict[str, Any]]:
    """The API's records (mm and degrees): point 1 the TCP's tracker record, points 2-4 reflector records."""
    out: list[dict[str, Any]] = []
    for q, points, sigma in zip(s.joints, s.points, s.sigma_mm, strict=True):
        joints = [q[0] * 1000.0, *np.degrees(q[1:]).tolist()]
        out.append({"joints": joints, "position": points[0].tolist(), "sigma_mm": float(sigma)})
        if reflectors:
            out += [
                {"kind": "reflector", "reflector": f"p{k + 1}", "joints": joints, "position": points[k].tolist()}
                | {"sigma_mm": float(sigma)}
                for k in range(1, POINTS)
            ]
    return out


# ------------------------------------------------------------------------- the independent fit (numpy, scipy)
def _rpy(r: float, p: float, y: float) -> np.ndarray:
    return Rotation.from_euler("xyz", [r, p, y]).as_matrix()


def _small(v: np.ndarray) -> np.ndarray:
    """(…, 6) translation (mm) and rotation vector (rad) → (…, 4, 4)."""
    v = np.atleast_2d(v)
    t = np.tile(np.eye(4), (v.shape[0], 1, 1))
    t[:, :3, :3] = Rotation.from_rotvec(v[:, 3:]).as_matrix()
    t[:, :3, 3] = v[:, :3]
    return t


@dataclass(frozen=True)
class Chain:
    """The URDF's joints from BASE to TIP as written: origin (mm), moving kind, axis."""

    joints: tuple[tuple[np.ndarray, str | None, np.ndarray], ...]

    @staticmethod
    def read(path: Path) -> Chain:
        root = ET.parse(path).getroot()
        by_child = {j.find("child").get("link"): j for j in root.iter("joint") if j.find("child") is not None}  # type: ignore[union-attr]
        found, at = [], TIP
        while at != BASE:
            joint = by_child[at]
            found.append(joint)
            at = str(joint.find("parent").get("link"))  # type: ignore[union-attr]
        out = []
        for joint in reversed(found):
            origin = joint.find("origin")
            assert origin is not None
            t = np.eye(4)
            t[:3, :3] = _rpy(*(float(v) for v in str(origin.get("rpy")).split()))
            t[:3, 3] = [float(v) * 1000.0 for v in str(origin.get("xyz")).split()]
            axis = joint.find("axis")
            direction = np.array([float(v) for v in str(axis.get("xyz")).split()]) if axis is not None else np.zeros(3)
            kind = joint.get("type")
            out.append((t, None if kind == "fixed" else str(kind), direction))
        return Chain(tuple(out))

    @property
    def moving(self) -> int:
        return sum(kind is not None for _, kind, _ in self.joints)

    @property
    def size(self) -> int:
        """base 6 | per moving joint: origin error 6 + offset 1 | the points' offsets 3 each."""
        return 6 + 7 * self.moving + 3 * POINTS

    def points(self, p: np.ndarray, q: np.ndarray) -> np.ndarray:
        """(N, 4, 3) the four points at joints q (torso m, arm rad) for parameters p (mm, rad)."""
        n = q.shape[0]
        t = np.repeat(_small(p[:6]), n, axis=0)
        k = 0
        for origin, kind, axis in self.joints:
            t = t @ origin
            if kind is None:
                continue
            error = p[6 + 7 * k : 13 + 7 * k]
            t = t @ _small(error[:6])
            value = q[:, k] * (1000.0 if kind == "prismatic" else 1.0) + error[6]
            motion = np.zeros((n, 6))  # along the axis (prismatic) or about it (revolute)
            columns = slice(0, 3) if kind == "prismatic" else slice(3, 6)
            motion[:, columns] = value[:, None] * axis
            t = t @ _small(motion)
            k += 1
        offsets = p[6 + 7 * self.moving :].reshape(POINTS, 3)
        return np.asarray(np.einsum("nij,kj->nki", t[:, :3, :3], offsets) + t[:, None, :3, 3], dtype=float)


def independent_fit(chain: Chain, s: Session) -> np.ndarray:
    """Base and points first (from a rigid fit of the flange to the points' centroid), then every parameter of
    the identifiable set (pivoted QR of the column-scaled Jacobian there), weighted by each posture's σ."""
    weight = 1.0 / s.sigma_mm[:, None, None]
    p = np.zeros(chain.size)
    flange = chain.points(p, s.joints)[:, 0]
    centroid = s.points.mean(axis=1)
    a, b = flange - flange.mean(axis=0), centroid - centroid.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    turn = vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
    p[:3], p[3:6] = centroid.mean(axis=0) - turn @ flange.mean(axis=0), Rotation.from_matrix(turn).as_rotvec()

    def fit(start: np.ndarray, free: np.ndarray) -> np.ndarray:
        def residuals(x: np.ndarray) -> np.ndarray:
            trial = start.copy()
            trial[free] = x
            return np.asarray(((chain.points(trial, s.joints) - s.points) * weight).ravel(), dtype=float)

        out = start.copy()
        out[free] = least_squares(residuals, start[free], method="lm").x
        return out

    p = fit(p, np.r_[np.arange(6), np.arange(6 + 7 * chain.moving, chain.size)])
    h = 1e-6
    columns = []
    for i in range(chain.size):
        step = np.zeros(chain.size)
        step[i] = h
        plus, minus = chain.points(p + step, s.joints), chain.points(p - step, s.joints)
        columns.append(((plus - minus) * weight).ravel() / (2 * h))
    jacobian = np.array(columns).T
    _, r, pivots = qr(jacobian / np.linalg.norm(jacobian, axis=0), pivoting=True, mode="economic")
    diagonal = np.abs(np.diag(r))
    rank = int(np.sum(diagonal > 1e-6 * diagonal[0]))
    assert rank == 42, rank  # 4R + 2P + 6 = 36 for the TCP's pose, less its 3 turns, plus 3 × 3 point offsets
    return fit(p, np.sort(pivots[:rank]))


def rms_mm(errors: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(errors**2, axis=-1))))


# ----------------------------------------------------------------------------------------- the service
@dataclass(frozen=True)
class Calibrated:
    report: dict[str, Any]
    validation: dict[str, Any]
    """The validation session against the nominal version (registered) and the applied one."""
    nominal: dict[str, Any]
    from_file: dict[str, Any]
    """The same campaign posted as the publisher's CSV file, to a second robot of the same URDF."""
    confirmations: tuple[dict[str, Any], ...]
    """The protocol's confirmation sessions against the applied version."""


@pytest.fixture(scope="module")
def calibrated(api: TestClient) -> Calibrated:
    return _calibrate(api, robot_file(URDF).read_text())


def _calibrate(client: TestClient, urdf: str) -> Calibrated:
    made = client.post("/v1/robots", json={"name": "tiago", "urdf": urdf, "base_link": BASE, "tip_link": TIP})
    assert made.status_code == 201, made.text
    robot = made.json()["id"]
    answer = client.post(f"/v1/robots/{robot}/calibrations", json={"measurements": records(session(TRAINING))})
    assert answer.status_code == 201, answer.text
    validation = records(session(VALIDATION), reflectors=False)
    checked = client.post(f"/v1/robots/{robot}/validations", json={"measurements": validation})
    assert checked.status_code == 201, checked.text
    nominal = client.post(
        f"/v1/robots/{robot}/validations", json={"measurements": validation, "versions": [1], "register": True}
    )
    assert nominal.status_code == 201, nominal.text
    confirmations = []
    for name in CONFIRMATION:
        held_out = client.post(
            f"/v1/robots/{robot}/validations", json={"measurements": records(session(name), reflectors=False)}
        )
        assert held_out.status_code == 201, held_out.text
        confirmations.append(held_out.json())
    twin = client.post("/v1/robots", json={"name": "tiago-file", "urdf": urdf, "base_link": BASE, "tip_link": TIP})
    assert twin.status_code == 201, twin.text
    from_file = client.post(
        f"/v1/robots/{twin.json()['id']}/calibrations",
        params=AS_SHIPPED,
        content=(DATA / TRAINING).read_bytes(),
        headers={"content-type": "text/csv"},
    )
    assert from_file.status_code == 201, from_file.text
    return Calibrated(answer.json(), checked.json(), nominal.json(), from_file.json(), tuple(confirmations))


@dataclass(frozen=True)
class Independent:
    chain: Chain
    parameters: np.ndarray


@pytest.fixture(scope="module")
def independent() -> Independent:
    chain = Chain.read(robot_file(URDF))
    return Independent(chain, independent_fit(chain, session(TRAINING)))


def held_out_rms(fit: Independent, name: str) -> float:
    """The independent fit's RMS on a held-out session's point 1."""
    held_out = session(name)
    return rms_mm(fit.chain.points(fit.parameters, held_out.joints)[:, 0] - held_out.points[:, 0])


@pytest.mark.slow  # the structure's first build, a 444-record calibration, two validations, a scipy fit: ~20 s
def test_one_call_with_defaults_calibrates_tiago_as_well_as_an_independent_fit(
    calibrated: Calibrated, independent: Independent
) -> None:
    report = calibrated.report
    assert report["status"] == "succeeded" and report["applied"], report["not_applied_reason"]
    assert report["record_kinds"] == {"position": 37, "reflector": 111}
    # The hand body's points 2-4 sit 10-20 cm from point 1 and are found without a guess.
    offsets = {r["name"]: np.linalg.norm(r["tool_offset_mm"]) for r in report["references"] if r["kind"] == "reflector"}
    assert set(offsets) == {"p2", "p3", "p4"} and all(50 < v < 300 for v in offsets.values()), offsets

    service = calibrated.validation["results"][0]["position_mm"]["rms"]
    nominal = calibrated.nominal["results"][0]["position_mm"]["rms"]
    independent_rms = held_out_rms(independent, VALIDATION)
    # Measured: 3.468 / 3.468 mm; the nominal geometry 71.3 mm even after the best rigid fit (the points'
    # offsets from arm_tool_link are unknown to it).
    assert service <= 1.05 * independent_rms, (service, independent_rms)
    assert service < 0.1 * nominal, (service, nominal)

    predicted = report["predicted_accuracy"]
    record = predicted["measured_region_record_rms_mm"]
    # A fresh record's predicted error where the campaign measured: 2.71 mm for 3.47 on another day (the model's
    # own uncertainty there, 0.84 mm, is a quarter of it: the rest is what no geometry describes).
    assert service / 2 <= record <= 2 * service, (record, service)
    assert predicted["measured_region_rms_position_mm"] < record


@pytest.mark.slow  # shares the module's calibrations and fit
def test_the_confirmation_sessions_agree_with_the_independent_fit(
    calibrated: Calibrated, independent: Independent
) -> None:
    # The protocol's two confirmation sessions (63 and 59 postures, 2021-11-30 14:03 and 15:04, before the
    # training session of 15:44). Measured: 1403 service 3.293 mm, independent 3.293 mm; 1504 service 2.776 mm,
    # independent 2.776 mm (ratio 1.0000 both).
    for name, answer in zip(CONFIRMATION, calibrated.confirmations, strict=True):
        service = answer["results"][0]["position_mm"]["rms"]
        independent_rms = held_out_rms(independent, name)
        assert service <= 1.05 * independent_rms, (name, service, independent_rms)


@pytest.mark.slow  # shares the module's calibrations
def test_the_publisher_s_file_as_shipped_calibrates_as_the_json_records_do(calibrated: Calibrated) -> None:
    """The training session's CSV as the publisher ships it (x1 … z4 in metres, the URDF's joint names, the torso
    in metres and the arm in radians with no unit in the header, marker_std_mm), posted as a file with
    length_unit=m and joint_unit=rad: the same records as the test's JSON, so the same calibration."""
    file, json_ = calibrated.from_file, calibrated.report
    assert file["status"] == "succeeded" and file["applied"], file["not_applied_reason"]
    assert file["record_kinds"] == json_["record_kinds"] == {"position": 37, "reflector": 111}
    by_name = {p["name"]: p["value"] for p in json_["parameters"]}
    got = {p["name"]: p["value"] for p in file["parameters"]}
    assert set(got) == set(by_name)
    scale = max(abs(v) for v in by_name.values())
    for name, value in by_name.items():
        assert got[name] == pytest.approx(value, rel=1e-9, abs=1e-9 * scale), name
    offsets = {r["name"]: r["tool_offset_mm"] for r in json_["references"] if r["kind"] == "reflector"}
    for reference in file["references"]:
        if reference["kind"] == "reflector":
            np.testing.assert_allclose(reference["tool_offset_mm"], offsets[reference["name"]], rtol=1e-9, atol=1e-9)
    notes = " ".join(file["notes"])
    assert "p1 read as the TCP's tracker records, p2, p3, p4 as reflector records" in notes, notes
    assert "joint column q1 is in m: converted to mm" in notes, notes


def test_the_sessions_are_the_publisher_s_files() -> None:
    """Each file's sha256 is the one SOURCE.md states (the publisher's protocol.yaml's): byte for byte as shipped."""
    stated = dict(
        re.findall(r"`(qualisys_[\w-]+\.csv)` \| \w+ \| \d+ \| `([0-9a-f]{64})`", (DATA / "SOURCE.md").read_text())
    )
    assert set(stated) == {TRAINING, VALIDATION, *CONFIRMATION}
    for name, digest in stated.items():
        assert hashlib.sha256((DATA / name).read_bytes()).hexdigest() == digest, name
