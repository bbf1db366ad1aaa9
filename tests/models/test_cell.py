"""The cell (models.cell): frames, default geometry, and check_poses against an independent hand-written check."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from models.cell import (
    Ballbar,
    Box,
    Camera,
    Cell,
    Obstacle,
    Reason,
    Segment,
    Target,
    Tracker,
    cell_for,
    check_poses,
    default_geometry,
    frame_layout,
    stage_frames,
)
from models.description.examples import ur5_like
from models.description.iwr import iwr
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.kinematics import forward_kinematics
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from models.workspace import sample_workspace
from tests.models.cell_reference import dh_frames, reference_verdicts, segment_distance

UR5 = ur5_like()
TABLE = Obstacle("table", Box(1500.0, 1500.0, 40.0), (0.0, 0.0, -21.0, 0.0, 0.0, 0.0))
FIXTURE = Obstacle("fixture", Box(300.0, 300.0, 300.0), (500.0, 300.0, 150.0, 0.0, 0.0, 0.2))


def ur5_cell(**tracker: object) -> Cell:
    options = {"acceptance": np.radians(60.0), **tracker}
    return cell_for(UR5, obstacles=(TABLE, FIXTURE), tracker=Tracker((2500.0, 0.0, 600.0), **options))


@pytest.mark.parametrize("desc", [UR5, ur5_like("mdh"), iwr()], ids=["dh", "mdh", "iwr"])
def test_the_last_frame_is_the_forward_kinematics(desc: RobotDescription) -> None:
    q = sample_workspace(desc, 64, seed=3)
    frames = stage_frames(desc, q)
    fk = forward_kinematics(desc, q)
    assert frames.shape == (64, len(frame_layout(desc).names), 4, 4)
    np.testing.assert_allclose(frames[:, -1, :3, 3], fk.positions, atol=1e-8)
    np.testing.assert_allclose(frames[:, -1, :3, :3], fk.rotations, atol=1e-12)


def test_every_frame_is_the_textbook_dh_product() -> None:
    q = sample_workspace(UR5, 200, seed=4)
    np.testing.assert_allclose(stage_frames(UR5, q), dh_frames(UR5, q), atol=1e-8)


def test_the_frames_function_is_built_once_per_structure() -> None:
    rt = Runtime(UR5)
    stage_frames(UR5, sample_workspace(UR5, 5, seed=1), runtime=rt)
    stage_frames(UR5, sample_workspace(UR5, 500, seed=2), runtime=rt)
    assert rt.builds.get("stage_frames") == 1


def test_default_capsules_follow_the_link_lengths() -> None:
    g = default_geometry(UR5)
    upper = [s for s in g.shapes if isinstance(s, Segment) and s.body == "link2"]
    assert {s.radius for s in upper} == {42.5}  # 0.1 x (|a| = 425 + |d| = 0)
    wrist = [s for s in g.shapes if isinstance(s, Segment) and s.body == "link6"]
    assert {s.radius for s in wrist} == {25.0}  # the floor: 0.1 x 82 is below it
    # The IWR's prismatic strokes are guides: no capsule runs along them; its legs are capsules
    iwr_g = default_geometry(iwr())
    assert not [s for s in iwr_g.shapes if isinstance(s, Segment) and s.body == "link1" and s.frame_a == "base"]
    assert len([s for s in iwr_g.shapes if s.body == "stage2"]) == 6


def test_default_allowed_pairs_are_adjacent_or_always_touching() -> None:
    cell = ur5_cell()
    allowed = {tuple(sorted(p)) for p in cell.allowed}
    assert ("link1", "table") in allowed  # the base column stands on the table
    assert ("fixture", "link3") not in allowed
    assert ("link2", "table") not in allowed  # the upper arm can hit it: never allowed
    assert {("link1", "link2"), ("link5", "link6"), ("link6", "tool")} <= allowed


@pytest.mark.slow  # ~2.5 s: 1 000 random poses against the hand-written check: outside the inner loop (make test-fast)
def test_check_agrees_with_the_hand_written_check_on_random_poses() -> None:
    cell = ur5_cell()
    q = sample_workspace(UR5, 1000, seed=11)
    got = check_poses(UR5, cell, q)
    ref, ambiguous = reference_verdicts(UR5, cell, q, dh_frames(UR5, q))
    clear = ~ambiguous
    assert clear.sum() > 830  # ~10 % have some distance within 1.5 mm of its threshold
    mismatch = [k for k in np.flatnonzero(clear) if got.reasons[k] != ref[k]]
    assert mismatch == []
    counts = got.counts
    # every kind of refusal the cell can make shows up, and feasible poses remain
    assert {"incidence", "self_collision", "cell_collision"} <= set(counts)
    assert got.feasible.sum() == len(q) - sum(counts.values()) > 30  # 82 of the 1 000


def test_a_pose_into_the_table_is_refused_naming_the_table() -> None:
    cell = cell_for(UR5, obstacles=(TABLE,))
    # Shoulder lift of +90°: the upper arm points straight down from the shoulder, through the table top
    q = np.array([[0.0, np.pi / 2, 0.0, 0.0, 0.0, 0.0]])
    elbow = dh_frames(UR5, q)[0, frame_layout(UR5).index("link2"), :3, 3]
    assert elbow[2] < -250  # the construction: the elbow is deep below the table's top
    got = check_poses(UR5, cell, q)
    assert got.reasons == (Reason.CELL_COLLISION.value,)
    assert "× table" in got.details[0]


def test_a_forearm_across_the_beam_blocks_it() -> None:
    q = np.array([[0.3, -1.2, 1.4, -0.8, 1.2, 0.4]])
    frames = dh_frames(UR5, q)[0]
    names = frame_layout(UR5).names
    forearm = 0.5 * (frames[names.index("link2"), :3, 3] + frames[names.index("link3"), :3, 3])
    reflector = frames[-1, :3, 3]
    # The tracker on the line from the reflector through the forearm's middle, 2 m beyond it
    direction = (forearm - reflector) / np.linalg.norm(forearm - reflector)
    tracker = Tracker(tuple(forearm + 2000.0 * direction), acceptance=np.pi)
    blocked = check_poses(UR5, cell_for(UR5, tracker=tracker), q)
    assert blocked.reasons == (Reason.LINE_OF_SIGHT.value,)
    assert blocked.details[0].endswith("link3")
    # The same pose seen from the side is measurable
    aside = np.cross(direction, [0.0, 0.0, 1.0])
    side = Tracker(tuple(reflector + 2500.0 * aside / np.linalg.norm(aside)), acceptance=np.pi)
    assert check_poses(UR5, cell_for(UR5, tracker=side), q).feasible.all()


def test_incidence_and_range_follow_the_reflector() -> None:
    q = np.array([[0.3, -1.2, 1.4, -0.8, 1.2, 0.4]])
    tcp = dh_frames(UR5, q)[0, -1]
    ahead = tcp[:3, 3] + 3000.0 * tcp[:3, 2]  # on the reflector's axis (it faces along the TCP's z)
    behind = tcp[:3, 3] - 3000.0 * tcp[:3, 2]
    assert check_poses(UR5, cell_for(UR5, tracker=Tracker(tuple(ahead))), q).feasible.all()
    assert check_poses(UR5, cell_for(UR5, tracker=Tracker(tuple(behind))), q).reasons == ("incidence",)
    far = Tracker(tuple(ahead), range_max=2000.0)
    assert check_poses(UR5, cell_for(UR5, tracker=far), q).reasons == ("out_of_range",)
    # A reflector turned by 90° about the TCP's x no longer faces the tracker on the old axis
    turned = Tracker(tuple(ahead), reflector=Target(facing=(0.0, 1.0, 0.0)))
    assert check_poses(UR5, cell_for(UR5, tracker=turned), q).reasons == ("incidence",)


def test_camera_field_of_view_and_ballbar_reach() -> None:
    q = np.array([[0.3, -1.2, 1.4, -0.8, 1.2, 0.4]])
    tcp = dh_frames(UR5, q)[0, -1]
    p, z = tcp[:3, 3], tcp[:3, 2]
    # A camera 1.5 m along the TCP's z, looking back at it (its z = -TCP z, a rotation of 180° about TCP x)
    look = tcp[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    pose = (*(p + 1500.0 * z), *matrix_to_rotvec_np(look))
    assert check_poses(UR5, cell_for(UR5, camera=Camera(pose)), q).feasible.all()
    # Turned 40° about its own y: the target leaves a 30° half-width
    turned = look @ rotvec_to_matrix_np(np.array([0.0, np.radians(40.0), 0.0]))
    pose2 = (*(p + 1500.0 * z), *matrix_to_rotvec_np(turned))
    assert check_poses(UR5, cell_for(UR5, camera=Camera(pose2)), q).reasons == ("field_of_view",)
    pivot = tuple(p + np.array([0.0, 0.0, -150.0]))
    assert check_poses(UR5, cell_for(UR5, ballbar=Ballbar(pivot, 100.0, 200.0)), q).feasible.all()
    assert check_poses(UR5, cell_for(UR5, ballbar=Ballbar(pivot, 160.0, 200.0)), q).reasons == ("ballbar_reach",)


def test_joint_limits_are_refused_first() -> None:
    q = np.zeros((2, 6))
    q[1, 2] = 4.0  # beyond ±π
    got = check_poses(UR5, cell_for(UR5), q)
    assert got.reasons[1] == "joint_limits" and "joint" in got.details[1]


def test_segment_distance_reference_is_right() -> None:
    # the reference itself, on cases with known answers: parallel, crossing, end to end
    p = np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0]])
    q = np.array([[10.0, 0, 0], [10, 0, 0], [10, 0, 0]])
    a = np.array([[0.0, 5, 0], [5, -5, 3], [13, 4, 0]])
    b = np.array([[10.0, 5, 0], [5, 5, 3], [20, 4, 0]])
    np.testing.assert_allclose(segment_distance(p, q, a, b), [5.0, 3.0, 5.0])


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: Tracker((0.0, 0.0, 0.0), acceptance=0.0), "tracker.acceptance"),
        (lambda: Tracker((0.0, 0.0, 0.0), beam_clearance=-1.0), "tracker.beam_clearance"),
        (lambda: Camera(acceptance=float("nan")), "camera.acceptance"),
        (lambda: Camera(acceptance=4.0), "camera.acceptance"),
        (lambda: Camera(sight_clearance=0.0), "camera.sight_clearance"),
        (lambda: Camera(sight_clearance=float("inf")), "camera.sight_clearance"),
    ],
)
def test_an_instruments_cone_and_clearance_are_checked_alike(make: Callable[[], object], field: str) -> None:
    # The camera's acceptance and sight clearance went unchecked (a NaN cone saw nothing, a negative clearance let
    # a sight line graze a link); the tracker's were checked.
    with pytest.raises(InvalidInput) as err:
        make()
    assert err.value.field == field


def test_bad_cells_are_refused_naming_the_field() -> None:
    with pytest.raises(InvalidInput, match=r"box\.x"):
        Box(-1.0, 1.0, 1.0)
    with pytest.raises(InvalidInput) as err:
        cell_for(UR5, obstacles=(TABLE,)).allowing(("link2", "nowhere"))
    assert err.value.field == "allowed"
    with pytest.raises(InvalidInput) as err:
        Tracker((0.0, 0.0, 0.0), range_min=5000.0, range_max=100.0)
    assert err.value.field == "tracker.range"
    with pytest.raises(InvalidInput) as err:
        check_poses(UR5, cell_for(UR5), np.zeros((2, 5)))
    assert err.value.field == "joints"
    with pytest.raises(InvalidInput) as err:
        Obstacle("table", Box(1.0, 1.0, 1.0), (0.0, 0.0, float("nan"), 0.0, 0.0, 0.0))
    assert err.value.field == "obstacles.pose"
    with pytest.raises(InvalidInput) as err:
        Cell(default_geometry(UR5), (TABLE, TABLE))
    assert err.value.field == "obstacles"
