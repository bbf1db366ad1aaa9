"""The KKT Newton's pieces (models.inverse.kkt): its batched solve and its active-set decisions, on hand-made
systems, multipliers and Jacobians whose answer is known by inspection."""

from __future__ import annotations

import numpy as np

from models.inverse.kkt import _released, _solve, _swapped

# Three orientation equations (rows: rotation about x, y, z) over six variables: v0 and v1 turn the tool about z,
# v2 about x, v3, v4 and v5 about y. With every variable that turns it about one axis fixed, the rest cannot
# satisfy the equations.
TURNS = np.array(
    [
        [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        [1.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    ]
)


def _mask(rows: list[list[int]], k: int = 6) -> np.ndarray:
    out = np.zeros((len(rows), k), dtype=bool)
    for i, row in enumerate(rows):
        out[i, row] = True
    return out


def test_one_release_a_round_the_most_wrong_in_box_widths() -> None:
    # Target 0: v0 at its lower bound pulled outwards by 2 per unit (wrong sign: the objective falls moving it
    # in), v1 at its upper bound by 1 per unit; v1's box is ten times wider, so in box widths v1 is the more
    # wrong (10 against 2). Target 1: v0 at its lower bound held there (the objective rises moving it in).
    grad = np.array([[-2.0, 1.0, 0.0], [3.0, 0.0, 0.0]])
    at_low = np.array([[True, False, False], [True, False, False]])
    at_high = np.array([[False, True, False], [False, False, False]])
    out = _released(grad, at_low, at_high, np.array([1.0, 10.0, 1.0]))
    assert out.tolist() == [[False, True, False], [False, False, False]]


def test_a_bound_that_leaves_an_axis_unturnable_is_swapped_for_the_one_held_least() -> None:
    n = 5
    jac = np.broadcast_to(TURNS, (n, 3, 6)).copy()
    fixed = _mask([[3, 5], [0, 3, 5], [3, 4], [0], [3, 4]])
    adding = _mask([[4], [4], [5], [4], [5]])
    held = np.tile([0.0, 0.0, 0.0, 0.5, 0.1, 0.9], (n, 1))  # bound multipliers in box widths
    where = np.array([True, True, True, True, False])
    out = _swapped(jac, fixed, adding, held, width=np.ones(6), where=where)
    # 0: v3, v4 and v5 fixed leave nothing turning about y; releasing v3 or v5 restores it, v3 held less.
    # 1: the same with v0 fixed too: v0 is held least, but releasing it does not help (v1 turns about z).
    # 2: v3 and v4 held, v5 added: releasing either restores y; v4 is held less (0.1 against 0.5).
    # 3: v0 and v4 fixed leave v1 (z), v2 (x), v3 and v5 (y): nothing to swap.
    # 4: as 2, but not a target to decide (its Newton did not converge).
    assert out.tolist() == _mask([[3], [3], [4], [], []]).tolist()


def test_a_singular_system_gets_nan_and_the_others_their_exact_steps() -> None:
    # Rows 0 and 2: diagonal systems, steps -f / diag. Row 1: a zero pivot (a joint held with nothing to move).
    jf = np.stack([np.diag([2.0, 4.0, 5.0]), np.diag([1.0, 0.0, 1.0]), np.diag([1.0, 1.0, 0.5])])
    f = np.array([[2.0, -4.0, 10.0], [1.0, 1.0, 1.0], [3.0, 0.0, -1.0]])
    out = _solve(jf, f)
    assert np.array_equal(out[[0, 2]], [[-1.0, 1.0, -2.0], [-3.0, 0.0, 2.0]])
    assert np.isnan(out[1]).all()
