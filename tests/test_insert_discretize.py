"""Discretized insertion (`MapperParams.discretize_rays`): one ray per lattice cell, to its centre.

Checked against the exact per-point traversal of the cells' centres (which has its own
brute-force test in ``test_occupancy.py``), by hand, and for the per-point counts.
"""

import hashlib
from dataclasses import replace

import numba
import numpy as np
import pytest

from mapper import FloorObstacleMapper, MapperParams
from mapper.errors import InvalidParameterError
from mapper.occupancy import (
    _EMPTY_SLOT,
    BEYOND_RANGE,
    NONFINITE,
    OUTSIDE,
    cell_set,
    insert_frame_columns,
    insert_with_scratch,
    lookup_tables,
    traversed_cells,
)

SHAPE = (12, 9, 6)
CELL, LAYER = 0.1, 0.07
ORIGIN = np.array([-0.2, 0.3, -0.1])  # grid corner x, y and z_min
SCALE = np.array([CELL, CELL, LAYER])
EXTENT = np.array(SHAPE) * SCALE


def _clustered_cloud(rng, clusters=80, per_cluster=6, beyond=0.6):
    """Points in clusters of 5 cm, inside the grid and up to ``beyond`` of its extent outside."""
    centres = ORIGIN + rng.uniform(-beyond, 1 + beyond, (clusters, 3)) * EXTENT
    spread = rng.uniform(-0.025, 0.025, (clusters, per_cluster, 3))
    return (centres[:, None, :] + spread).reshape(-1, 3)


def _cell_centres(points):
    """World centres of the distinct lattice cells holding ``points`` (numpy, any order)."""
    cells = np.unique(np.floor((points - ORIGIN) / SCALE).astype(np.int64), axis=0)
    return ORIGIN + (cells + 0.5) * SCALE


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
@pytest.mark.parametrize("free_margin_m", [0.0, 0.15])
@pytest.mark.parametrize("max_range_m", [np.inf, 1.0])
@pytest.mark.parametrize("clear_outside", [True, False])
def test_discretized_equals_exact_rays_to_the_cell_centres(
    columns, free_margin_m, max_range_m, clear_outside
):
    """The marks of a clustered cloud are those of the exact rays to its cells' centres."""
    rng = np.random.default_rng(7)
    geometry = (*ORIGIN, CELL, LAYER)
    kw = {"columns": columns, "max_range_m": max_range_m, "clear_outside": clear_outside}
    kw["free_margin_m"] = free_margin_m
    differs_from_points = 0
    for _ in range(4):
        sensor = ORIGIN + rng.uniform(-0.3, 1.3, 3) * EXTENT
        points = _clustered_cloud(rng)
        centres = _cell_centres(points)
        assert len(centres) < len(points) / 2  # several points share a cell
        disc = traversed_cells(points, sensor, geometry, SHAPE, discretize=True, **kw)
        exact = traversed_cells(centres, sensor, geometry, SHAPE, **kw)
        assert np.array_equal(disc[0], exact[0]) and np.array_equal(disc[1], exact[1])
        per_point = traversed_cells(points, sensor, geometry, SHAPE, **kw)
        differs_from_points += not np.array_equal(disc[0], per_point[0])
    assert differs_from_points > 0  # the rays to the points would have marked other cells


def test_discretized_hits_are_the_points_cells():
    """Without a range limit the hit cells are exactly the cells holding points in the grid."""
    rng = np.random.default_rng(11)
    sensor = ORIGIN + np.array([0.5, 0.5, 1.4]) * EXTENT  # above the grid
    points = _clustered_cloud(rng, beyond=0.0)
    geometry = (*ORIGIN, CELL, LAYER)
    _, disc_hits = traversed_cells(points, sensor, geometry, SHAPE, 0.1, discretize=True)
    _, exact_hits = traversed_cells(points, sensor, geometry, SHAPE, 0.1)
    assert len(exact_hits) > 80
    assert np.array_equal(disc_hits, exact_hits)


def _insert(points, sensor, discretize, columns, params):
    """One frame into a fresh (SHAPE) grid with ``params``' tables: (result, point_cell, og)."""
    og = np.full(SHAPE, 128, dtype=np.uint8)
    options = (params.free_margin_m, params.max_range_m, True, discretize)
    result, point_cell = insert_with_scratch(
        points, sensor, (*ORIGIN, CELL, LAYER), og, lookup_tables(params), options, columns
    )
    return result, point_cell, og


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
def test_one_cell_of_points_is_one_ray_by_hand(columns):
    """Three points in cell (9, 6, 2), the sensor at the centre of (2, 4, 2), all in layer 2.

    The ray to the end cell's centre, (2.5, 4.5) -> (9.5, 6.5) in cells, crosses y = 5 at
    x = 4.25 and y = 6 at x = 7.75: it clears columns (2..4, 4), (4..7, 5), (7..8, 6). The
    ray to the point at (9.1, 6.9) would cross y = 5 at x = 3.875, in column 3.
    """
    params = MapperParams(p_sense=0.7, p_min=0.12, p_max=0.97, free_margin_m=0.0)
    centre = ORIGIN + (np.array([9, 6, 2]) + 0.5) * SCALE
    points = centre + np.array([[0.0, 0.0, 0.0], [-0.04, 0.04, 0.0], [0.03, -0.03, 0.02]])
    sensor = ORIGIN + (np.array([2, 4, 2]) + 0.5) * SCALE
    result, point_cell, og = _insert(points, sensor, True, columns, params)
    used, nonfinite, outside, beyond, cells, ix0, ix1, iy0, iy1 = result
    assert (used, nonfinite, outside, beyond, cells) == (3, 0, 0, 0, 10)
    assert (ix0, ix1, iy0, iy1) == (2, 10, 4, 7)
    assert point_cell.tolist() == [9 * SHAPE[1] + 6] * 3
    cleared = [(2, 4), (3, 4), (4, 4), (4, 5), (5, 5), (6, 5), (7, 5), (7, 6), (8, 6)]
    expected = np.full(SHAPE, 128, dtype=np.uint8)
    for ix, iy in cleared:
        expected[ix, iy, 2] = 77  # one miss (HAND sensor model)
    expected[9, 6, 2] = 179  # one hit
    assert np.array_equal(og, expected)
    _, _, per_point = _insert(points, sensor, False, columns, params)
    assert per_point[3, 5, 2] == 77 and og[3, 5, 2] == 128


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
def test_points_take_their_cells_status(columns):
    """Counts and codes per point: outside, beyond range (of the centre), non-finite."""
    params = MapperParams(free_margin_m=0.0, max_range_m=0.5)
    sensor = ORIGIN + (np.array([2, 4, 2]) + 0.5) * SCALE
    inside = ORIGIN + (np.array([4, 4, 2]) + 0.5) * SCALE  # centre 0.2 m away: a hit
    far = ORIGIN + (np.array([9, 4, 2]) + 0.5) * SCALE  # centre 0.7 m away: beyond range
    beside = ORIGIN + (np.array([-3, 4, 2]) + 0.5) * SCALE  # outside the grid, 0.5 m away
    points = np.array(
        [inside, inside + 0.01, far, far - 0.04, beside, beside + 0.02, [np.nan, 0.0, 0.0]]
    )
    result, point_cell, _ = _insert(points, sensor, True, columns, params)
    assert result[:4] == (2, 1, 2, 2)
    hit = 4 * SHAPE[1] + 4
    expected = [hit, hit, BEYOND_RANGE, BEYOND_RANGE, OUTSIDE, OUTSIDE, NONFINITE]
    assert point_cell.tolist() == expected


def test_discretize_rays_must_be_a_bool():
    assert MapperParams(discretize_rays=True).discretize_rays is True
    with pytest.raises(InvalidParameterError, match=r"discretize_rays.*a bool"):
        MapperParams(discretize_rays=1)


@pytest.mark.parametrize("column_marks", [True, False], ids=["column-marks", "cell-marks"])
def test_the_mapper_passes_discretize_rays_to_its_kernel(column_marks):
    """A mapper with the field on maps a cloud as one without maps its cells' centres."""
    rng = np.random.default_rng(5)
    points = np.column_stack(
        [rng.uniform(0.9, 1.3, 3000), rng.uniform(-0.2, 0.2, 3000), rng.uniform(0.0, 0.2, 3000)]
    )
    sensor = np.array([0.0, 0.0, 0.9])
    params = MapperParams(free_margin_m=0.0)
    on = FloorObstacleMapper(replace(params, discretize_rays=True), column_marks=column_marks)
    off = FloorObstacleMapper(params, column_marks=column_marks)
    cells, valid = on.cell_of(points)
    assert valid.all()
    centres = np.unique(on.cell_center(cells[:, 0], cells[:, 1], cells[:, 2]), axis=0)
    assert len(centres) < len(points) / 2
    no_floor = np.full(len(points), np.nan)
    on.update(points, no_floor, sensor)
    off.update(centres, np.full(len(centres), np.nan), sensor)
    assert np.array_equal(on.occupancy_levels(), off.occupancy_levels())
    per_point = FloorObstacleMapper(params, column_marks=column_marks)
    per_point.update(points, no_floor, sensor)
    assert not np.array_equal(on.occupancy_levels(), per_point.occupancy_levels())


# The discretized path is compiled only for a `cell_set` scratch (None: numba prunes it), so the
# default run does not compile it; these pin that the change kept every result of before.
_BEFORE = {  # sha256[:16] of the updates' results, levels and floor map, made with c2da7ee
    (False, True): "f7e9c1351cb062ac",
    (False, False): "f7e9c1351cb062ac",
    (True, True): "5d72aab94ae66f6a",
    (True, False): "5cc48bcddf7023ed",
}


def _mapper_digest(discretize: bool, columns: bool) -> str:
    """Six synthetic frames (a noisy floor, a box, points beyond the grid) through a mapper."""
    rng = np.random.default_rng(2029)
    params = replace(MapperParams(), discretize_rays=discretize)
    fog = FloorObstacleMapper(params, column_marks=columns)
    digest = hashlib.sha256()
    for k in range(6):
        sensor = np.array([0.1 * k, -0.05 * k, 0.9])
        floor = rng.uniform(-2.2, 2.2, (400, 2))
        floor_points = np.column_stack([floor, rng.normal(0.0, 0.004, 400)])
        box = rng.uniform([0.3, -0.4, 0.0], [0.7, 0.1, 0.35], (150, 3))
        far = rng.uniform(-4.0, 4.0, (50, 3))
        points = np.concatenate([floor_points, box, far])
        heights = np.concatenate([np.zeros(400), np.full(200, np.nan)])
        fog.recenter(float(sensor[0]), float(sensor[1]))
        digest.update(repr(fog.update(points, heights, sensor)).encode())
    digest.update(fog.occupancy_levels().tobytes())
    digest.update(np.asarray(fog.floor(), dtype=np.float64).tobytes())
    return digest.hexdigest()[:16]


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
@pytest.mark.parametrize("discretize", [False, True], ids=["per-point", "discretized"])
def test_the_mapper_maps_as_before_the_discretized_path_was_split_off(discretize, columns):
    assert _mapper_digest(discretize, columns) == _BEFORE[discretize, columns]


def test_the_cell_set_holds_twice_the_points_in_a_power_of_two():
    for n, capacity in ((0, 1), (1, 2), (3, 8), (4, 8), (5, 16), (5950, 16384)):
        keys, codes = cell_set(n)
        assert keys.shape == (capacity, 3) and keys.dtype == np.int64
        assert codes.shape == (capacity,) and codes.dtype == np.int8
        assert np.all(codes == _EMPTY_SLOT)


@pytest.mark.slow  # compiles the column kernel twice (about 10 s of CPU)
def test_the_column_kernel_without_a_cell_set_has_no_discretized_path():
    """Compiled afresh (no cache) for ``cells=None``: the lattice hash of `_discretized` is not
    in its code; with a cell set it is (so the test would see it)."""
    options = {k: v for k, v in insert_frame_columns.targetoptions.items() if k != "nopython"}
    kernel = numba.njit(**{**options, "cache": False})(insert_frame_columns.py_func)
    params = MapperParams()
    fog = FloorObstacleMapper(params)
    g = fog.geometry
    points = np.array([[0.3, 0.2, 0.1], [0.5, -0.1, 0.2]])
    for cells, hashed in ((None, False), (cell_set(len(points)), True)):
        args = (
            points,
            np.array([0.0, 0.0, 0.9]),
            *g.origin_xy_m,
            g.z_min_m,
            g.cell_m,
            g.layer_m,
            fog.occupancy_levels().copy(),
            fog._hit_cols,
            fog._miss_cols,
            fog._range_masks,
            fog._update_table,
            np.empty(len(points), dtype=np.int64),
            params.free_margin_m,
            float(params.max_range_m),
            True,
            cells,
        )
        kernel(*args)
        llvm = kernel.inspect_llvm(kernel.signatures[-1])
        assert ("73856093" in llvm) == hashed
