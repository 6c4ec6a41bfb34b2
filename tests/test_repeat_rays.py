"""`MapperParams.repeat_ray_columns`: rays to an end cell already hit this frame walk only their
last columns (`mapper.occupancy._repeat_start`), against the exact insertion."""

import numpy as np
import pytest

from mapper import FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.errors import InvalidParameterError
from mapper.synthetic import Box, camera_rays_world, cast_frame

CAMERA = np.array([0.0, 0.0, 0.7])


def _levels(points, camera, **fields) -> np.ndarray:
    """The occupancy levels after one frame (no floor) on a fresh grid centred at the origin."""
    mapper = FloorObstacleMapper(MapperParams(**fields))
    mapper.update(points, np.full(len(points), np.nan), camera)
    return mapper.occupancy_levels()


def _frame(seed: int = 3):
    rng = np.random.default_rng(seed)
    rays = camera_rays_world(PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0), 10.0, 25.0)
    boxes = [Box((0.9, 0.3), (0.4, 0.4, 0.07)), Box((1.2, -0.5), (0.3, 0.3, 0.25))]
    points, _ = cast_frame(CAMERA, rays, boxes, max_range_m=3.5, noise_z_m=0.005, rng=rng)
    return points[np.all(np.isfinite(points), axis=1)]


def _one_point_per_cell(points) -> np.ndarray:
    """The first point of each lattice cell (grid centred at the origin, default cell sizes)."""
    g = FloorObstacleMapper(MapperParams()).geometry
    corner = np.array([*g.origin_xy_m, g.z_min_m])
    cells = np.floor((points - corner) / [g.cell_m, g.cell_m, g.layer_m]).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return points[np.sort(first)]


def test_duplicated_points_give_the_exact_map():
    """Each end cell's one point given twice: the second ray's last columns lie on the first
    ray, so the map is the exact one (the shortened walk marks nothing the whole walk would
    not)."""
    points = _one_point_per_cell(_frame())
    twice = np.repeat(points, 2, axis=0)
    exact = _levels(twice, CAMERA)
    for k in (1, 2, 4):
        np.testing.assert_array_equal(_levels(twice, CAMERA, repeat_ray_columns=k), exact)


@pytest.mark.parametrize("k", [1, 2, 4])
def test_same_hits_fewer_misses_than_exact(k):
    """One frame of a floor with two boxes: the same cells hit, the cleared cells a subset of
    the exact insertion's, and fewer (the later rays to a cell were shortened)."""
    points = _frame()
    exact = _levels(points, CAMERA)
    ours = _levels(points, CAMERA, repeat_ray_columns=k)
    np.testing.assert_array_equal(ours > 128, exact > 128)  # hits: the end cells, identical
    ours_missed, exact_missed = ours < 128, exact < 128
    assert not np.any(ours_missed & ~exact_missed)
    assert 0 < np.sum(exact_missed & ~ours_missed) < 0.05 * np.sum(exact_missed)


def test_a_repeated_end_cell_clears_only_its_last_columns():
    """Two points in one cell, seen along +x from 0.7 m: the second ray (offset in y so that it
    crosses other columns than the first far from the end) clears its last two columns as the
    exact insertion does, and none of its own columns far from the end."""
    first = np.array([1.601, 0.0205, 0.01])
    second = np.array([1.639, 0.0395, 0.01])
    sensor = np.array([0.0, -0.5, 0.7])  # the rays cross y columns on their way
    both = np.stack([first, second])
    alone = _levels(second[None], sensor) < 128  # the second ray's exact cleared cells
    first_only = _levels(first[None], sensor) < 128
    ours = _levels(both, sensor, repeat_ray_columns=2) < 128
    ix_end = np.nonzero((_levels(second[None], sensor) > 128).any(axis=(1, 2)))[0][0]
    near = np.zeros_like(alone)
    near[ix_end - 1 :] = True
    assert np.any(alone & near)
    assert np.all(ours[alone & near])  # its last columns: cleared
    far_own = alone & ~first_only
    far_own[ix_end - 4 :] = False
    assert np.any(far_own)  # the second ray has cells of its own far from its end ...
    assert not np.any(ours[far_own])  # ... which the shortened walk leaves alone


def test_bad_values_named():
    with pytest.raises(InvalidParameterError, match="repeat_ray_columns"):
        MapperParams(repeat_ray_columns=-1)
    with pytest.raises(InvalidParameterError, match="repeat_ray_columns"):
        MapperParams(repeat_ray_columns=1.5)
    with pytest.raises(InvalidParameterError, match="column marks"):
        FloorObstacleMapper(MapperParams(repeat_ray_columns=2), column_marks=False)
