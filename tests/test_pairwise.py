"""`mapper.pairwise`: numpy's pairwise sum, bit for bit (the tilt filter's and z-matching's)."""

import numpy as np
import pytest

from mapper.pairwise import block_sum, pairwise_sum


@pytest.mark.parametrize(
    "n", [0, 1, 5, 7, 8, 9, 15, 16, 127, 128, 129, 136, 255, 256, 257, 300, 1001, 5000, 70001]
)
def test_pairwise_sum_is_numpys(n):
    rng = np.random.default_rng(n)
    values = rng.normal(size=n) * 10.0 ** rng.integers(-6, 6, n)
    assert pairwise_sum(values) == values.sum()
    assert pairwise_sum(values) == np.add.reduce(values)


def test_pairwise_sum_of_special_values_is_numpys():
    # inf and NaN propagate as numpy's. Zeros compare equal; their sign may not: numpy adds the
    # pairwise sum to its reduction's identity 0.0 and so turns a sum of -0.0 into +0.0, the
    # kernel does not (nor did either copy it replaces: results unchanged).
    for values in (
        [-0.0],
        [-0.0] * 9,
        [np.inf, 1.0],
        [np.inf, -np.inf] * 100,
        [np.nan] + [1.0] * 200,
    ):
        array = np.array(values)
        got, want = pairwise_sum(array), array.sum()
        assert (np.isnan(got) and np.isnan(want)) or got == want


@pytest.mark.parametrize("start,n", [(0, 0), (3, 5), (1, 8), (2, 19), (5, 128)])
def test_block_sum_of_a_run_is_numpys(start, n):
    values = np.random.default_rng(start + n).normal(size=200) * 1e3
    assert block_sum(values, np.int64(start), np.int64(n)) == values[start : start + n].sum()
