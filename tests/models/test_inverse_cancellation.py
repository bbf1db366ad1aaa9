"""Inverse kinematics stops when told to (models.engine.cancellation), also inside its IPOPT stage."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from models import Registry, RobotDescription, forward_kinematics, sample_workspace
from models.engine import cancellation
from models.inverse.solve import inverse_kinematics


@pytest.mark.serial  # stopped within 0.2 s of slack past the chunk it was in: alone on the cores
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_unreachable_targets_stop_within_one_chunk_of_ipopt(desc: RobotDescription) -> None:
    """Targets 3 m above the workspace: Newton fails, exact IPOPT fails, nearest IPOPT finds the closest pose:
    ~30 ms a target, all of it in the IPOPT stage. Cancelled after 0.3 s, the call stops within a chunk."""
    rt = Registry().runtime(desc)
    far = forward_kinematics(desc, sample_workspace(desc, 120, seed=2), runtime=rt).positions + np.array(
        [0.0, 0.0, 3000.0]
    )
    started = time.perf_counter()
    whole = inverse_kinematics(desc, far[:8], runtime=rt)
    per_target = (time.perf_counter() - started) / 8
    assert set(whole.methods) == {"ipopt-nearest"} and np.all(whole.position_error_mm > 1000)
    token = cancellation.CancellationToken()
    threading.Timer(0.3, token.cancel).start()
    started = time.perf_counter()
    with pytest.raises(cancellation.Cancelled), cancellation.cancellable(token):
        inverse_kinematics(desc, far, runtime=rt)
    stopped = time.perf_counter() - started
    assert stopped < 0.3 + 2 * 8 * per_target + 0.2, (stopped, per_target)  # the whole would take 120 targets' time
    assert 120 * per_target > 3 * stopped
