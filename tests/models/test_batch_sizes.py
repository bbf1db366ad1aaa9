"""The batch engine pads a batch to one of a few map sizes: the answers are the rows' own, whatever the size."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from models.engine.batch import EXACT_UP_TO, BatchFunctions, padded_size


def _functions() -> BatchFunctions:
    x = ca.SX.sym("x", 3)
    m = ca.SX.sym("m", 2, 2)
    p = ca.SX.sym("p", 2)
    f = ca.Function("f", [x, m, p], [ca.vertcat(x[0] * p[0] + x[1] ** 2, ca.sin(x[2]) + p[1]), m @ m.T * x[0]])
    return BatchFunctions(functions={"f": f}, native={"f": f})


@pytest.mark.parametrize("n", [1, EXACT_UP_TO, EXACT_UP_TO + 1, 70, 257, 1000, 1025])
def test_a_padded_batch_answers_each_row_as_numpy_does(n: int) -> None:
    rng = np.random.default_rng(n)
    x, m, p = rng.normal(size=(n, 3)), rng.normal(size=(n, 2, 2)), np.array([0.5, -2.0])
    fns = _functions()
    vec, mat = fns.batch("f", x, m, p)
    assert vec.shape == (n, 2) and mat.shape == (n, 2, 2)
    assert np.allclose(vec, np.c_[x[:, 0] * 0.5 + x[:, 1] ** 2, np.sin(x[:, 2]) - 2.0])
    assert np.allclose(mat, m @ m.transpose(0, 2, 1) * x[:, 0, None, None])
    assert {size for _, size in fns._maps} == {padded_size(n)}


def test_padded_sizes_repeat_and_waste_at_most_an_eighth() -> None:
    sizes = [padded_size(n) for n in range(1, 20_001)]
    assert all(n <= s <= max(n, n * 9 / 8) for n, s in zip(range(1, 20_001), sizes, strict=True))
    assert sizes[:EXACT_UP_TO] == list(range(1, EXACT_UP_TO + 1))
    # A batch shrinking from 10 000 to 1 000 one row at a time meets few sizes: eight per doubling.
    assert len({padded_size(n) for n in range(1_000, 10_001)}) <= 8 * 4 + 1
