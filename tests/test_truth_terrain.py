"""The ground truth of the real staircase (``eth_stairs``) at its landing's riser, by hand.

The terrain's image (71 rows × 64 columns, 0.04 m spacing) lies turned by 180° about
(2.26, 0.5): its column 63 (local x = +1.26 m) is the world line x = 1.00 m, the landing's riser,
which falls on a boundary of the mapper's cells (centres -1.98 + 0.04 k). Rows 33-36 (local
y = 1.4 - 0.04 row) are world y 0.56..0.44; their samples in columns 60-63 read 79 (one 75),
79 / 255 × 1.25 m = 0.3873 m. So the cells centred at x = 0.98 m are ground at 0 m in full
(Table I's ``ground`` row), those at 1.02 m the landing (no Table I row: the terrain is no
walkable box). A map whose ground row reads 0.38 m there carries the landing's height over the
riser; the truth does not.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.world import SceneTruth, TruthLabel

CELL_M = 0.04
LANDING_M = 79 / 255 * 1.25


@pytest.fixture(scope="module")
def truth() -> SceneTruth:
    return SceneTruth.from_scenario(load_scenario("eth_stairs"), 0.0)


def cells(xs, ys) -> np.ndarray:
    return np.stack(np.meshgrid(np.asarray(xs), np.asarray(ys), indexing="ij"), axis=-1)


def test_the_column_before_the_riser_is_ground_and_the_next_the_landing(truth):
    grid = truth.rasterize(cells([0.94, 0.98, 1.02, 1.06], [0.46, 0.5, 0.54]), CELL_M)
    assert np.all(grid.labels == TruthLabel.FLOOR)
    assert np.all(grid.interior)  # the riser lies on the cell boundary x = 1.00 m
    ground = grid.surface_names.index("ground")
    np.testing.assert_array_equal(grid.floor_m[:2], 0.0)
    np.testing.assert_array_equal(grid.surface_id[:2], ground)
    np.testing.assert_allclose(grid.floor_m[2:], LANDING_M, atol=1e-12)
    np.testing.assert_array_equal(grid.surface_id[2:], -1)


def test_a_terrain_truth_round_trips_through_json_and_rasterises_the_same(truth):
    again = SceneTruth.from_dict(json.loads(json.dumps(truth.to_dict())))
    assert again == truth
    centers = cells(np.arange(0.9, 3.6, CELL_M), np.arange(-0.8, 1.8, CELL_M))
    before, after = truth.rasterize(centers, CELL_M), again.rasterize(centers, CELL_M)
    np.testing.assert_array_equal(after.labels, before.labels)
    np.testing.assert_array_equal(after.floor_m, before.floor_m)
    # The terrain is no box: its 0.95 m top is not the truth everywhere on it.
    assert np.nanmax(before.floor_m) < 0.6 and np.any(before.floor_m > 0.5)
