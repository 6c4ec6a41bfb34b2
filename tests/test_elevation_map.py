"""The elevation map against known answers: the noise model, the Kalman update by hand on one
cell, the gating that keeps the higher surface, the visibility clean-up."""

import math

import numpy as np
import pytest

from mapper import CellType, InvalidParameterError, MapperParams
from mapper.elevation_map import ElevationMap, ElevationMapParams, point_height_variance_m2

CELL = (50, 50)  # the cell of world (0.02, 0.02) on the default grid centred on (0, 0)
NO_FLOOR = np.array([np.nan])
# σ_n = 0.01 + 0.01·d² [m], no lateral noise: easy numbers by hand
SIMPLE = ElevationMapParams(
    normal_a_m=0.01,
    normal_b_per_m=0.01,
    normal_c_m=0.0,
    lateral_factor=0.0,
    min_variance_m2=1e-6,
    max_variance_m2=1e-2,
)


def one_point(emap, xyz, origin):
    return emap.update(np.array([xyz], dtype=float), NO_FLOOR, np.array(origin, dtype=float))


def test_the_noise_model_is_the_structured_light_model_projected_on_z():
    p = ElevationMapParams()
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    origin = np.array([0.0, 0.0, 1.0])  # straight down (u_z² = 1) and at 45° (u_z² = 1/2)
    sigma_n1 = 0.000611 + 0.003587 * (1.0 - 0.3515) ** 2
    d2 = math.sqrt(2.0)
    sigma_n2 = 0.000611 + 0.003587 * (d2 - 0.3515) ** 2
    sigma_l2 = 0.01576 * d2
    expected = [sigma_n1**2, 0.5 * sigma_n2**2 + 0.5 * sigma_l2**2]
    np.testing.assert_allclose(point_height_variance_m2(points, origin, p), expected, rtol=1e-12)


def test_the_kalman_update_on_one_cell_by_hand():
    emap = ElevationMap(SIMPLE)
    one_point(emap, (0.02, 0.02, 0.0), (0.02, 0.02, 1.0))  # d = 1: σ = 0.02, σ² = 4e-4
    assert emap.heights()[CELL] == 0.0
    assert emap.variance()[CELL] == pytest.approx(4e-4, rel=1e-12)
    one_point(emap, (0.02, 0.02, 0.03), (0.02, 0.02, 2.03))  # d = 2: σ = 0.05, σ² = 2.5e-3
    # |0.03 − 0| / 0.02 = 1.5 < 2.5: fused. h = (4e-4·0.03 + 2.5e-3·0) / 2.9e-3
    assert emap.heights()[CELL] == pytest.approx(1.2e-5 / 2.9e-3, rel=1e-12)  # 4.138 mm
    assert emap.variance()[CELL] == pytest.approx(4e-4 * 2.5e-3 / 2.9e-3, rel=1e-12)
    assert np.isnan(emap.heights()[CELL[0] + 1, CELL[1]])  # nothing else was touched


def test_gating_keeps_the_higher_surface_within_a_frame_and_adds_noise_across_frames():
    emap = ElevationMap(SIMPLE)
    origin = np.array([0.02, 0.02, 1.0])
    # one frame: the floor, then a 20 cm top in the same cell (10 σ apart): the top replaces it
    emap.update(np.array([[0.02, 0.02, 0.0], [0.02, 0.02, 0.2]]), np.full(2, np.nan), origin)
    assert emap.heights()[CELL] == 0.2
    assert emap.variance()[CELL] == pytest.approx((0.01 + 0.01 * 0.8**2) ** 2, rel=1e-12)
    before = emap.variance()[CELL]
    # a lower point in a later frame is not fused: it only adds the multi-height noise
    one_point(emap, (0.02, 0.02, 0.0), origin)
    assert emap.heights()[CELL] == 0.2
    assert emap.variance()[CELL] == pytest.approx(before + SIMPLE.multi_height_noise_m2)
    # within one frame a lower point after a higher one is ignored
    emap2 = ElevationMap(SIMPLE)
    emap2.update(np.array([[0.02, 0.02, 0.2], [0.02, 0.02, 0.0]]), np.full(2, np.nan), origin)
    assert emap2.heights()[CELL] == 0.2


def test_the_visibility_cleanup_removes_a_cell_a_ray_passes_beneath():
    # a 0.3 m top at x = 0.5 m; then a ray from (0.02, 0.02, 0.2) to the floor at x = 1.0 m
    # passes through that column at z ≈ 0.10 m: the top would have blocked it, so it is gone
    for origin_z, kept in ((0.2, False), (1.0, True)):
        emap = ElevationMap(SIMPLE)
        one_point(emap, (0.5, 0.02, 0.3), (0.5, 0.02, 1.3))
        box = emap.geometry.cell_of(np.array([[0.5, 0.02]]))[0][0]
        assert emap.heights()[box[0], box[1]] == pytest.approx(0.3)
        result = one_point(emap, (1.0, 0.02, 0.0), (0.02, 0.02, origin_z))
        # origin 1.0 m: the ray crosses x = 0.5 at z ≈ 0.51 m, above the top: it stays
        assert np.isnan(emap.heights()[box[0], box[1]]) != kept
        assert result.cells_updated == (0 if kept else 1)
        floor = emap.geometry.cell_of(np.array([[1.0, 0.02]]))[0][0]
        assert emap.heights()[floor[0], floor[1]] == 0.0  # the ray's own end is fused


def test_fog_labels_by_the_step_rule_and_recenter_scrolls():
    emap = ElevationMap(SIMPLE)
    one_point(emap, (0.02, 0.02, 0.0), (0.02, 0.02, 1.0))
    types, heights = emap.fog()
    assert types[CELL] == CellType.FLOOR and heights[CELL] == 0.0
    assert (types != CellType.UNKNOWN).sum() == 1
    assert emap.recenter(0.06, 0.02) == (1, 0)  # one cell along x
    assert emap.heights()[CELL[0] - 1, CELL[1]] == 0.0
    assert np.isfinite(emap.heights()).sum() == 1


def test_points_outside_the_grid_are_dropped_and_counted():
    emap = ElevationMap(SIMPLE)
    points = np.array([[0.02, 0.02, 5.0], [10.0, 0.0, 0.0], [np.nan, 0.0, 0.0]])
    result = emap.update(points, np.full(3, np.nan), np.array([0.0, 0.0, 1.0]))
    assert (result.points_used, result.points_dropped_outside) == (0, 2)
    assert result.points_dropped_nonfinite == 1
    assert np.isnan(emap.heights()).all()


@pytest.mark.parametrize(
    "field, value",
    [("mahalanobis_threshold", 0.0), ("normal_a_m", -1.0), ("max_variance_m2", 1e-7)],
)
def test_bad_parameters_name_the_field(field, value):
    with pytest.raises(InvalidParameterError, match=field):
        ElevationMapParams(**{field: value})


def test_the_grid_follows_the_mapper_params():
    emap = ElevationMap(grid=MapperParams(nx=10, ny=12))
    assert emap.heights().shape == (10, 12)
