"""Something above the grid's top makes its column an obstacle (`mapper.above_top`).

The default grid's top is z_min + nz·layer = −0.06 + 16·0.04 = 0.58 m; delta_m is 0.05, so a
hit lies in (0.63, 0.58 + reach]. The frames below: a sensor at (0.1, 0.1, 0.9) over a grid
of 20 × 20 cells of 0.04 m from (0, 0); a "tread" of floor points at 0.56 m (the top layer,
0.54–0.58) over x in [0.4, 0.6), and a "riser" column of points at 0.70 m at x = 0.62.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.above_top import MIN_HIT_POINTS, update_above_top
from mapper.grid import GridGeometry
from mapper.occupancy import lookup_tables


class AboveTopColumns:
    """Reference: a frame's hit and missed columns (flat ``ix * ny + iy``, none in both).

    Attributes:
        hit: (H,) int64 columns with a point just above the grid's top.
        miss: (M,) int64 columns whose top face a ray crossed downwards (and no point hit).
    """

    __slots__ = ("hit", "miss")

    def __init__(self, hit: NDArray[np.int64], miss: NDArray[np.int64]) -> None:
        self.hit = hit
        self.miss = miss


def _columns(
    xy: NDArray[np.float64], geometry: GridGeometry, min_points: int = 1
) -> NDArray[np.int64]:
    """Flat columns holding at least ``min_points`` of the world (x, y) points, sorted."""
    ox, oy = geometry.origin_xy_m
    fx = np.floor((xy[:, 0] - ox) / geometry.cell_m)
    fy = np.floor((xy[:, 1] - oy) / geometry.cell_m)
    inside = (fx >= 0) & (fx < geometry.nx) & (fy >= 0) & (fy < geometry.ny)
    flat = fx[inside].astype(np.int64) * geometry.ny + fy[inside].astype(np.int64)
    columns, counts = np.unique(flat, return_counts=True)
    return columns[counts >= min_points]


def above_top_columns(
    points: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    geometry: GridGeometry,
    min_above_m: float,
    reach_m: float,
    max_range_m: float,
) -> AboveTopColumns:
    """Reference in numpy: the columns a frame hits and misses just above the grid's top.

    Args:
        points: (N, 3) world points [m] (rows with NaN or inf are left out).
        sensor_origin: (3,) world sensor position [m].
        geometry: The grid (its top is ``geometry.z_max_m``).
        min_above_m: A hit lies more than this above the top [m] (``delta_m``).
        reach_m: ... and at most this above it [m] (``above_top_reach_m``).
        max_range_m: Points farther from the sensor are no hit [m]; their rays still miss.
    """
    top = geometry.z_max_m
    finite = np.isfinite(points).all(axis=1)
    pts = points[finite]
    offset = pts - sensor_origin
    length = np.sqrt((offset * offset).sum(axis=1))
    height = pts[:, 2] - top
    is_hit = (height > min_above_m) & (height <= reach_m) & (length <= max_range_m)
    hit = _columns(pts[is_hit], geometry, MIN_HIT_POINTS)
    oz = float(sensor_origin[2])
    if oz > top:
        down = pts[:, 2] < top
        t = (oz - top) / (oz - pts[down, 2])  # in (0, 1): where the ray crosses the top face
        t_max = np.minimum(1.0, max_range_m / np.maximum(length[down], 1e-12))
        crossing = t <= t_max
        xy = sensor_origin[:2] + t[crossing, None] * offset[down][crossing, :2]
        miss = np.setdiff1d(_columns(xy, geometry), hit, assume_unique=True)
    else:
        miss = np.empty(0, dtype=np.int64)
    return AboveTopColumns(hit, miss)


def apply_above_top(
    levels: NDArray[np.uint8],
    columns: AboveTopColumns,
    hit_table: NDArray[np.uint8],
    miss_table: NDArray[np.uint8],
) -> None:
    """One frame's update of the (nx, ny) levels in place: table lookups, a column once."""
    flat = levels.reshape(-1)
    flat[columns.hit] = hit_table[flat[columns.hit]]
    flat[columns.miss] = miss_table[flat[columns.miss]]


GRID = dict(nx=20, ny=20)
SENSOR = np.array([0.1, 0.1, 0.9])
TREAD_Z = 0.56
ROW_Y = 0.42  # the cells of row iy = 10


def tread_frame(riser_z: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Floor points on the tread (x cells 10-14, row 10) and, with ``riser_z``, a point at
    that height in column (15, 10) (x = 0.62)."""
    xs = np.arange(0.41, 0.6, 0.01)
    points = [np.array([x, ROW_Y, TREAD_Z]) for x in xs]
    heights = [TREAD_Z] * len(points)
    if riser_z is not None:
        points += [np.array([0.62, ROW_Y, riser_z])] * 3
        heights += [np.nan] * 3
    return np.array(points), np.array(heights)


def fog_of(params: MapperParams, frames: list[tuple[np.ndarray, np.ndarray]]):
    mapper = FloorObstacleMapper(params, center_xy_m=(0.4, 0.4))
    for points, heights in frames:
        mapper.update(points, heights, SENSOR)
    return mapper.fog()


def test_a_point_above_the_top_makes_its_column_an_obstacle_at_the_top():
    params = MapperParams(**GRID, above_top_reach_m=0.6)
    assert params.z_max_m == pytest.approx(0.58)
    types, heights = fog_of(params, [tread_frame(0.70)] * 4)
    assert types[15, 10] == CellType.OBSTACLE
    assert heights[15, 10] == pytest.approx(0.58)
    assert (types[10:15, 10] == CellType.FLOOR).all()  # the tread itself stays a floor
    # Off: the riser's column holds nothing the grid can see.
    assert MapperParams().above_top_reach_m == 0.6  # on by default
    types_off, _ = fog_of(MapperParams(**GRID, above_top_reach_m=0.0), [tread_frame(0.70)] * 4)
    assert types_off[15, 10] != CellType.OBSTACLE


@pytest.mark.parametrize("riser_z", [0.60, 0.63, 1.30])
def test_points_within_delta_of_the_top_or_beyond_the_reach_do_not_count(riser_z):
    # 0.60 and 0.63 lie within delta (0.05) of the top (a top-layer surface's noise); 1.30 is
    # beyond 0.58 + 0.6.
    params = MapperParams(**GRID, above_top_reach_m=0.6)
    types, _ = fog_of(params, [tread_frame(riser_z)] * 4)
    assert types[15, 10] != CellType.OBSTACLE


def test_rays_crossing_the_top_face_clear_the_column_again():
    # Hits for 4 frames, then the riser is gone: a ray to the ground beyond crosses the top
    # face inside column (15, 10), and its misses take the column's level back below p_occ.
    params = MapperParams(**GRID, above_top_reach_m=0.6)
    mapper = FloorObstacleMapper(params, center_xy_m=(0.4, 0.4))
    for _ in range(4):
        mapper.update(*tread_frame(0.70), SENSOR)
    assert mapper.fog()[0][15, 10] == CellType.OBSTACLE
    # A ray from the sensor crosses z = 0.58 at (0.62, 0.42) when it ends on the ground (z = 0)
    # at x = 0.1 + (0.62 - 0.1) · 0.9 / (0.9 - 0.58) = 1.5625, y = 0.1 + 0.32 · 0.9 / 0.32 = 1.0.
    ground = np.array([[1.5625, 0.1 + (ROW_Y - 0.1) * 0.9 / 0.32, 0.0]])
    columns = above_top_columns(ground, SENSOR, mapper.geometry, 0.05, 0.6, np.inf)
    assert columns.miss.tolist() == [15 * 20 + 10] and columns.hit.size == 0
    for _ in range(12):
        mapper.update(ground, np.array([np.nan]), SENSOR)
    assert mapper.fog()[0][15, 10] != CellType.OBSTACLE


def test_a_hit_wins_over_a_miss_in_one_frame():
    geometry = GridGeometry.from_params(MapperParams(**GRID), (0.4, 0.4))
    riser = [[0.62, ROW_Y, 0.7]] * MIN_HIT_POINTS
    ground = np.array([[1.5625, 0.1 + (ROW_Y - 0.1) * 0.9 / 0.32, 0.0], *riser])
    columns = above_top_columns(ground, SENSOR, geometry, 0.05, 0.6, np.inf)
    assert columns.hit.tolist() == [15 * 20 + 10] and columns.miss.size == 0


def test_a_single_stray_point_is_no_hit():
    geometry = GridGeometry.from_params(MapperParams(**GRID), (0.4, 0.4))
    assert MIN_HIT_POINTS == 2
    one = np.array([[0.62, ROW_Y, 0.7]])
    assert above_top_columns(one, SENSOR, geometry, 0.05, 0.6, np.inf).hit.size == 0
    assert (
        above_top_columns(np.repeat(one, 2, axis=0), SENSOR, geometry, 0.05, 0.6, np.inf).hit.size
        == 1
    )


def test_points_beyond_the_range_are_no_hit():
    geometry = GridGeometry.from_params(MapperParams(**GRID), (0.4, 0.4))
    far = np.array([[0.62, ROW_Y, 0.7]] * MIN_HIT_POINTS)
    assert above_top_columns(far, SENSOR, geometry, 0.05, 0.6, 0.5).hit.size == 0
    assert above_top_columns(far, SENSOR, geometry, 0.05, 0.6, 1.0).hit.size == 1


def test_the_column_scrolls_with_the_grid():
    params = MapperParams(**GRID, above_top_reach_m=0.6)
    mapper = FloorObstacleMapper(params, center_xy_m=(0.4, 0.4))
    for _ in range(4):
        mapper.update(*tread_frame(0.70), SENSOR)
    assert mapper.recenter(0.48, 0.4) == (2, 0)
    assert mapper.fog()[0][13, 10] == CellType.OBSTACLE


def test_a_negative_reach_is_refused_with_the_allowed_values():
    with pytest.raises(InvalidParameterError, match=r"above_top_reach_m.*>= 0"):
        MapperParams(above_top_reach_m=-0.1)


@pytest.mark.parametrize("seed", range(6))
def test_the_kernel_updates_the_levels_as_the_numpy_steps_do(seed):
    # Random frames around the top (some beyond the range, some NaN, the sensor above or below
    # the top): the same levels after each frame, the scratch zero again.
    rng = np.random.default_rng(seed)
    params = MapperParams(**GRID, above_top_reach_m=0.6)
    geometry = GridGeometry.from_params(params, (0.4, 0.4))
    hit_table, miss_table = lookup_tables(params)
    ours = np.full((20, 20), 128, dtype=np.uint8)
    theirs = ours.copy()
    counts = np.zeros(400, dtype=np.int32)
    for frame in range(8):
        n = 300
        points = np.column_stack(
            [rng.uniform(-0.2, 1.0, n), rng.uniform(-0.2, 1.0, n), rng.uniform(0.3, 1.3, n)]
        )
        points[rng.random(n) < 0.05] = np.nan
        # Columns with many points above the top, so that hits occur.
        points[:40, :2] = rng.uniform(0.3, 0.5, (40, 2))
        points[:40, 2] = rng.uniform(0.64, 1.1, 40)
        sensor = np.array([0.1, 0.1, 0.9 if frame % 3 else 0.5])
        max_range = 1.2 if frame % 2 else np.inf
        columns = above_top_columns(points, sensor, geometry, 0.05, 0.6, max_range)
        apply_above_top(theirs, columns, hit_table, miss_table)
        ox, oy = geometry.origin_xy_m
        touched = np.empty(n, dtype=np.int64)
        update_above_top(
            points, sensor, ox, oy, geometry.cell_m, geometry.z_max_m, 0.05, 0.6, max_range,
            ours, counts, touched, hit_table, miss_table, MIN_HIT_POINTS,
        )  # fmt: skip
        np.testing.assert_array_equal(ours, theirs)
        assert not counts.any()
    assert (theirs > 128).any() and (theirs < 128).any()  # both kinds of update happened
