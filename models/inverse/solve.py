"""Inverse kinematics: joint commands that put a robot's TCP on target.

For each target (position and orientation, or position only) the joints
closest to a seed among all solutions within every range: carriage joints
within their ranges, legs within their strokes, the platform inside the
hexapod's workspace (where its condition number stays far from singular).

Route: a starting point from the nearest of a few thousand reachable poses of
the model (k-d tree, `starts.py`), then Newton on the KKT conditions for all
targets at once (`kkt.py`). Where that lands inside every bound it is the
solution of the IPOPT problem (`nlp.py`); the others are solved by IPOPT
itself, and targets IPOPT cannot reach exactly get the nearest reachable pose
and the reason. Every answer is checked by forward kinematics through the
hexapod's own forward solution.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.description.robot import RobotDescription
from models.engine import cancellation
from models.engine.runtime import Runtime, runtime_for
from models.errors import NonFiniteValue
from models.inverse.problem import joint_weights
from models.inverse.report import IkSolution, report
from models.inverse.routing import joints_of, route
from models.inverse.targets import seeds_for, validated_targets


def inverse_kinematics(
    desc: RobotDescription,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    params: ArrayLike | None = None,
    *,
    seed: ArrayLike | None = None,
    weights: ArrayLike | None = None,
    follow: bool = False,
    runtime: Runtime | None = None,
) -> IkSolution:
    """Joint commands reaching each target on the robot with parameters `params` (internal units).

    `quaternions` None: position-only targets (orientation free). `seed`: one joint vector, or one per target
    (default: `default_seed`). `follow`: each target's seed is the previous target's answer, so a path stays
    smooth (the first uses `seed`). `weights`: per joint, multiplying the range-normalised distance to the seed.
    """
    started = time.perf_counter()
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    if not np.isfinite(theta).all():
        raise NonFiniteValue("the parameters contain non-finite numbers")
    p, rot, reasons = validated_targets(positions, quaternions)
    n = p.shape[0]
    seeds = seeds_for(desc, seed, n)
    w = joint_weights(desc, weights)
    position_only = rot is None
    valid = np.array([r is None for r in reasons])
    rot_all = rot if rot is not None else np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    target = np.hstack([p, rot_all.transpose(0, 2, 1).reshape(n, 9)])
    target[~valid] = 0.0

    v = np.full((n, desc.n_ik), np.nan)
    methods = ["invalid"] * n
    if follow:
        previous: Array | None = None
        for i in np.flatnonzero(valid):
            cancellation.check()
            s = seeds[i : i + 1] if previous is None else previous
            vi, mi = route(desc, theta, target[i : i + 1], s, w, position_only=position_only, runtime=rt)
            v[i], methods[i] = vi[0], mi[0]
            previous = joints_of(desc, theta, vi)
    else:
        idx = np.flatnonzero(valid)
        if idx.size:
            vi, mi = route(desc, theta, target[idx], seeds[idx], w, position_only=position_only, runtime=rt)
            v[idx] = vi
            for k, i in enumerate(idx):
                methods[i] = mi[k]
    return report(desc, theta, v, p, rot, reasons=reasons, methods=methods, started=started, runtime=rt)
