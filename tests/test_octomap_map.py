"""OctoMap read as heights: the top face of the highest occupied voxel per column."""

import numpy as np
import pytest

pytest.importorskip("octomap", reason="octomap-python not installed")

from mapper import CellType, InvalidParameterError, MapperParams
from mapper.octomap_map import OctoMapHeights, OctoMapParams


def insert(m, points, origin):
    pts = np.array(points, dtype=float)
    return m.update(pts, np.full(len(pts), np.nan), np.array(origin, dtype=float))


def test_heights_are_the_tops_of_the_highest_occupied_voxels():
    m = OctoMapHeights()  # z_min −0.06, layers of 4 cm: faces at −0.02, 0.02, …, 0.14, …
    result = insert(m, [[0.02, 0.02, 0.13], [0.02, 0.02, 0.01], [0.06, 0.02, -0.03]], (0, 0, 1))
    assert result.points_used == 3
    h = m.heights()
    assert h[50, 50] == pytest.approx(0.14, abs=1e-6)  # voxel [0.10, 0.14): top 0.14
    assert h[51, 50] == pytest.approx(-0.02, abs=1e-6)  # voxel [−0.06, −0.02)
    assert np.isfinite(h).sum() == 2  # the ray's free voxels are no heights
    types, heights = m.fog()
    assert types[50, 50] == CellType.OBSTACLE  # 16 cm step within the foot window
    np.testing.assert_array_equal(heights, h)


def test_rays_free_a_voxel_they_cross_and_the_window_follows_recenter():
    m = OctoMapHeights()
    insert(m, [[0.50, 0.02, 0.30]], (0.50, 0.02, 1.3))  # one hit: occupied (0.7 > 0.5)
    ix = 50 + 12
    assert m.heights()[ix, 50] == pytest.approx(0.34, abs=1e-6)
    for _ in range(3):  # rays through that voxel to the floor beyond: misses clear it
        insert(m, [[1.0, 0.02, 0.0]], (0.02, 0.02, 0.58))
    assert np.isnan(m.heights()[ix, 50])
    assert m.recenter(0.42, 0.02) == (10, 0)
    assert m.heights()[50 + 15, 50] == pytest.approx(0.02, abs=1e-6)  # the floor at x = 1.0


def test_voxels_must_be_cubes_and_parameters_are_checked():
    with pytest.raises(InvalidParameterError, match="layer_m"):
        OctoMapHeights(grid=MapperParams(layer_m=0.02))
    with pytest.raises(InvalidParameterError, match="occupancy_threshold"):
        OctoMapParams(occupancy_threshold=0.99)
