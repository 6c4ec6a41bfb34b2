"""`mapper.floor_cover._kept_heights`: numpy's unique-then-merge, written out without a sort."""

import numpy as np
import pytest

from mapper.floor_cover import frame_floor_heights


def reference(heights: np.ndarray, eps: float) -> np.ndarray:
    """The definition: the finite heights' ``np.unique``, each kept unless within ``eps``
    above the last kept one."""
    kept: list[float] = []
    for h in np.unique(heights[np.isfinite(heights)]):
        if not kept or h > kept[-1] + eps:
            kept.append(float(h))
    return np.array(kept)


@pytest.mark.parametrize("seed", range(8))
def test_kept_heights_equal_numpy_unique_on_runs_of_random_heights(seed):
    """Runs of repeated heights in any order, with NaN and ±inf among them, as in a frame."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        values = np.r_[rng.normal(0.0, 0.1, rng.integers(1, 40)), np.nan, np.inf, -np.inf, 0.0]
        picks = rng.choice(values, rng.integers(0, 200))
        heights = np.repeat(picks, rng.integers(1, 6, picks.shape[0]))
        eps = float(rng.choice([0.0, 0.005, 0.02]))
        got = frame_floor_heights(heights, eps)
        want = reference(heights, eps)
        assert got.tolist() == want.tolist()


def test_kept_heights_of_a_descending_and_an_equal_sequence():
    """Every value inserted at the front (the longest shifts), and one value seen many times."""
    heights = np.linspace(0.5, -0.5, 101)
    assert frame_floor_heights(heights, 0.0).tolist() == reference(heights, 0.0).tolist()
    assert frame_floor_heights(np.full(50, 0.25), 0.01).tolist() == [0.25]
    assert frame_floor_heights(np.array([0.1, 0.2, 0.1, 0.2]), 0.0).tolist() == [0.1, 0.2]
