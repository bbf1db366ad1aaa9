"""Example structures (`shared/spec/robots.md` documents) of the robot families the project calibrates.

Geometries from public datasheets, rounded: they are test and benchmark subjects, not vendor models.
- `ur5_like`: a 6R arm in standard DH (Universal Robots' published UR5 DH table, mm);
  `ur5_like("dh-beta")` the same table with Hayati's `beta` on its two parallel-axis links (README "Any
  robot": a `dh` link with alpha 0 or ±180° may carry one);
- `iiwa_like`: a 7R arm in modified DH (KUKA LBR iiwa 14's published link lengths 360/420/400/126 mm);
- `track_arm`: the UR5-like arm (in MDH) on a 2 m linear track (a prismatic first link): seven axes;
- `hexapod_alone`: a Stewart–Gough platform on its own (not the IWR's geometry).
"""

from __future__ import annotations

import math
from typing import Any

from models.description.robot import RobotDescription
from models.description.structure import Document, description_from_document

_IDENTITY_POSE: dict[str, list[float]] = {"position": [0.0, 0.0, 0.0], "orientation": [1.0, 0.0, 0.0, 0.0]}


def _link(joint: str, dh: tuple[float, float, float, float], limits: tuple[float, float]) -> dict[str, Any]:
    """A link from its (a, alpha, d, theta) and its range."""
    a, alpha, d, theta = dh
    return {"joint": joint, "a": a, "alpha": alpha, "d": d, "theta": theta, "range": list(limits)}


UR5_DH: list[dict[str, Any]] = [
    _link("revolute", (0.0, 90.0, 89.159, 0.0), (-180.0, 180.0)),
    _link("revolute", (-425.0, 0.0, 0.0, 0.0), (-180.0, 180.0)),
    _link("revolute", (-392.25, 0.0, 0.0, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, 90.0, 109.15, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, -90.0, 94.65, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, 0.0, 82.3, 0.0), (-180.0, 180.0)),
]

IIWA_MDH: list[dict[str, Any]] = [
    _link("revolute", (0.0, 0.0, 360.0, 0.0), (-170.0, 170.0)),
    _link("revolute", (0.0, -90.0, 0.0, 0.0), (-120.0, 120.0)),
    _link("revolute", (0.0, 90.0, 420.0, 0.0), (-170.0, 170.0)),
    _link("revolute", (0.0, 90.0, 0.0, 0.0), (-120.0, 120.0)),
    _link("revolute", (0.0, -90.0, 400.0, 0.0), (-170.0, 170.0)),
    _link("revolute", (0.0, -90.0, 0.0, 0.0), (-120.0, 120.0)),
    _link("revolute", (0.0, 90.0, 126.0, 0.0), (-175.0, 175.0)),
]


UR5_MDH: list[dict[str, Any]] = [
    # The same arm in Craig's convention: row i takes alpha_{i-1}, a_{i-1} of the DH table's row i-1 and d_i,
    # theta_i of its row i (the DH table's last a, alpha are 0: nothing moves to the tool).
    _link("revolute", (0.0, 0.0, 89.159, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, 90.0, 0.0, 0.0), (-180.0, 180.0)),
    _link("revolute", (-425.0, 0.0, 0.0, 0.0), (-180.0, 180.0)),
    _link("revolute", (-392.25, 0.0, 109.15, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, 90.0, 94.65, 0.0), (-180.0, 180.0)),
    _link("revolute", (0.0, -90.0, 82.3, 0.0), (-180.0, 180.0)),
]

PROBE: dict[str, list[float]] = {"position": [60.0, -40.0, 120.0], "orientation": [1.0, 0.0, 0.0, 0.0]}
"""A probe off the last joint's axis: with the TCP on that axis the last joint would not move it, and a
position-only calibration would lose that joint's parameters (measured: 29 instead of 31 on the 7R arm)."""


UR5_PARALLEL_LINKS = (1, 2)
"""The UR5 DH table's links with alpha 0 between joint axes (2 ∥ 3, 3 ∥ 4); the sixth's alpha 0 is the flange."""


def ur5_like_document(convention: str = "dh") -> Document:
    """`dh`, `mdh`, or `dh-beta` (standard DH with Hayati's beta on the parallel-axis links)."""
    links = [dict(r) for r in (UR5_MDH if convention == "mdh" else UR5_DH)]
    if convention == "dh-beta":
        for k in UR5_PARALLEL_LINKS:
            links[k]["beta"] = 0.0
    stage = {"kind": "serial", "convention": "mdh" if convention == "mdh" else "dh", "links": links}
    return {"tool": PROBE, "stages": [stage]}


def iiwa_like_document() -> Document:
    return {"tool": PROBE, "stages": [{"kind": "serial", "convention": "mdh", "links": [dict(r) for r in IIWA_MDH]}]}


def track_arm_document() -> Document:
    # The track slides along the base's z axis, parallel to the arm's first axis: MDH with Hayati's beta
    # keeps that pair (and the arm's parallel shoulder and elbow) identifiable.
    track = _link("prismatic", (0.0, 0.0, 0.0, 0.0), (0.0, 2000.0))
    links = [track, *(dict(r) for r in UR5_MDH)]
    return {"tool": PROBE, "stages": [{"kind": "serial", "convention": "mdh", "links": links}]}


def _circle(radius: float, angles_deg: tuple[float, ...], z: float = 0.0) -> list[list[float]]:
    return [[radius * math.cos(math.radians(a)), radius * math.sin(math.radians(a)), z] for a in angles_deg]


def hexapod_alone_document() -> Document:
    return {
        "stages": [
            {
                "kind": "hexapod",
                "base_joints": _circle(200.0, (-10.0, 10.0, 110.0, 130.0, 230.0, 250.0)),
                "platform_joints": _circle(100.0, (-50.0, 50.0, 70.0, 170.0, 190.0, 290.0)),
                "strokes": [260.0, 420.0],
                "home": {"position": [0.0, 0.0, 300.0], "orientation": [1.0, 0.0, 0.0, 0.0]},
                "workspace": {
                    "x": [-30.0, 30.0],
                    "y": [-30.0, 30.0],
                    "z": [270.0, 330.0],
                    "rz": [-8.0, 8.0],
                    "ry": [-8.0, 8.0],
                    "rx": [-8.0, 8.0],
                },
            }
        ]
    }


def ur5_like(convention: str = "dh") -> RobotDescription:
    return description_from_document(ur5_like_document(convention), name="ur5-like")


def iiwa_like() -> RobotDescription:
    return description_from_document(iiwa_like_document(), name="iiwa-like")


def track_arm() -> RobotDescription:
    return description_from_document(track_arm_document(), name="track-arm")


def hexapod_alone() -> RobotDescription:
    return description_from_document(hexapod_alone_document(), name="hexapod")
