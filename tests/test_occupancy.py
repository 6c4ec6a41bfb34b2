"""8-bit Bayes tables and exact ray insertion, against hand-computed values and brute force."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mapper import FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.errors import InvalidParameterError
from mapper.occupancy import bayes_update, lookup_tables, traversed_cells
from mapper.synthetic import Box, camera_rays_world, cast_frame


def test_tables_by_hand():
    # p_sense = 0.7, p = L/256, clamps 0.12 (level 31) and 0.97 (level 248).
    hit, miss = lookup_tables(MapperParams())
    # 128 (0.5) -> 0.7*0.5/(0.7*0.5+0.3*0.5) = 0.7 -> 179.2 -> 179
    assert hit[128] == 179
    # 179/256=0.69922 -> 0.84434 -> 216.15 -> 216
    assert hit[179] == 216
    # 216/256=0.84375 -> 0.92647 -> 237.18 -> 237
    assert hit[216] == 237
    # 128 -> 0.3 -> 76.8 -> 77; 77/256=0.30078 -> 0.15566 -> 39.85 -> 40;
    # 40/256=0.15625 -> 0.07353 -> clamped to p_min -> level 31
    assert (miss[128], miss[77], miss[40]) == (77, 40, 31)
    assert hit[248] == 248 and miss[31] == 31
    assert hit.max() == 248 and miss.min() == 31


def test_tables_monotone_and_never_stall():
    p = MapperParams(p_sense=0.52)  # weak model: rounding alone would stall near the clamps
    hit, miss = lookup_tables(p)
    levels = np.arange(p.level_min, p.level_max + 1)
    assert np.all(hit[levels[:-1]] > levels[:-1])
    assert np.all(miss[levels[1:]] < levels[1:])
    assert np.all(np.diff(hit.astype(int)) >= 0) and np.all(np.diff(miss.astype(int)) >= 0)


def test_bayes_update_matches_eq6():
    assert bayes_update(0.5, 0.7) == pytest.approx(0.7)
    assert bayes_update(0.7, 0.7) == pytest.approx(0.49 / (0.49 + 0.09))


PAPER = MapperParams(free_margin_m=0.0)  # rays clear every cell before the end cell


def _one_ray_mapper(params=PAPER):
    # Grid origin (-2, -2); sensor at the centre of cell (50, 50, 2), point in cell (60, 50, 2).
    m = FloorObstacleMapper(params)
    sensor = np.array([0.02, 0.02, 0.04])
    point = np.array([[0.42, 0.02, 0.04]])
    return m, sensor, point


@pytest.mark.parametrize(("frames", "free", "end"), [(1, 77, 179), (2, 40, 216), (30, 31, 248)])
def test_one_ray_by_hand(frames, free, end):
    m, sensor, point = _one_ray_mapper()
    for _ in range(frames):
        result = m.update(point, [np.nan], sensor)
    levels = m.occupancy_levels()
    assert np.all(levels[50:60, 50, 2] == free)
    assert levels[60, 50, 2] == end
    changed = np.argwhere(levels != 128)
    assert len(changed) == 11
    assert result.affected_area.slices == (slice(50, 61), slice(50, 51))
    assert result.cells_updated == 11
    assert m.occupancy()[60, 50, 2] == pytest.approx(end / 256)


def test_once_per_frame_hit_wins():
    """Two rays crossing the same cells in one frame update them once; a hit beats a miss."""
    m, sensor, _ = _one_ray_mapper()
    # Ray A ends in cell (60, 50, 2); ray B passes through (60, 50, 2) and ends in (70, 50, 2).
    points = np.array([[0.42, 0.02, 0.04], [0.82, 0.02, 0.04]])
    m.update(points, [np.nan, np.nan], sensor)
    levels = m.occupancy_levels()
    assert np.all(levels[50:60, 50, 2] == 77)  # crossed by both rays: one miss, not two (40)
    assert levels[60, 50, 2] == 179  # end of A, crossed by B: hit
    assert np.all(levels[61:70, 50, 2] == 77)
    assert levels[70, 50, 2] == 179


def test_many_points_in_one_cell_are_one_hit():
    m, sensor, _ = _one_ray_mapper()
    points = np.array([[0.41, 0.01, 0.03], [0.42, 0.02, 0.04], [0.43, 0.03, 0.05]])
    m.update(points, [np.nan] * 3, sensor)
    assert m.occupancy_levels()[60, 50, 2] == 179


def test_free_margin_stops_clearing_before_the_end():
    m, sensor, point = _one_ray_mapper(MapperParams(free_margin_m=0.08))
    m.update(point, [np.nan], sensor)
    levels = m.occupancy_levels()[:, 50, 2]
    # end at x=0.42 (cell 60); clearing stops at x=0.34 (cell 58, cleared too); 59 untouched
    assert np.all(levels[50:59] == 77)
    assert levels[59] == 128 and levels[60] == 179


def test_sensor_above_grid_clears_top_layers():
    m = FloorObstacleMapper(PAPER)
    sensor = np.array([0.02, 0.02, 1.0])  # 0.42 m above the grid's top (0.58 m)
    point = np.array([[0.02, 0.02, 0.0]])  # straight down, cell (50, 50, 1)
    m.update(point, [np.nan], sensor)
    levels = m.occupancy_levels()[50, 50]
    assert levels[1] == 179
    assert np.all(levels[2:] == 77)
    assert levels[0] == 128


# ---------------------------------------------------------------- brute-force reference
SHAPE = (7, 6, 5)
CELL, LAYER = 0.1, 0.07
ORIGIN = (-0.2, 0.3, -0.1)  # grid corner x, y and z_min


def _reference(sensor, end):
    """Cells whose box the segment sensor->end crosses with positive length (slab test)."""
    ix, iy, iz = np.meshgrid(*(np.arange(n) for n in SHAPE), indexing="ij")
    lo = np.stack(
        [ORIGIN[0] + ix * CELL, ORIGIN[1] + iy * CELL, ORIGIN[2] + iz * LAYER], axis=-1
    ).reshape(-1, 3)
    hi = lo + np.array([CELL, CELL, LAYER])
    d = end - sensor
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = (lo - sensor) / d
        tb = (hi - sensor) / d
    t_in = np.where(
        d == 0, np.where((sensor >= lo) & (sensor < hi), -np.inf, np.inf), np.minimum(ta, tb)
    )
    t_out = np.where(
        d == 0, np.where((sensor >= lo) & (sensor < hi), np.inf, -np.inf), np.maximum(ta, tb)
    )
    t0 = np.maximum(t_in.max(axis=1), 0.0)
    t1 = np.minimum(t_out.min(axis=1), 1.0)
    length = (t1 - t0) * np.linalg.norm(d)
    return length


coord = st.floats(-1.0, 1.5, allow_nan=False, allow_infinity=False)


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
@settings(max_examples=300, deadline=None, derandomize=True)
@given(
    sensor=st.tuples(coord, coord, coord),
    end_frac=st.tuples(st.floats(0, 0.999), st.floats(0, 0.999), st.floats(0, 0.999)),
)
def test_traversal_equals_brute_force(columns, sensor, end_frac):
    sensor = np.array(sensor)
    extent = np.array([SHAPE[0] * CELL, SHAPE[1] * CELL, SHAPE[2] * LAYER])
    end = np.array(ORIGIN) + np.array(end_frac) * extent
    miss, hit = traversed_cells(end[None], sensor, (*ORIGIN, CELL, LAYER), SHAPE, columns=columns)
    end_cell = np.ravel_multi_index(
        tuple(np.floor((end - ORIGIN) / [CELL, CELL, LAYER]).astype(int)), SHAPE
    )
    assert hit.tolist() == [end_cell]
    length = _reference(sensor, end)
    expected = set(np.flatnonzero(length > 1e-9).tolist()) - {end_cell}
    got = set(miss.tolist())
    # cells the segment only grazes (numerically zero length) may go either way
    for cell in expected ^ got:
        assert length[cell] < 1e-6, (cell, length[cell])
    assert end_cell not in got


@pytest.mark.parametrize("nz", [5, 16, 40, 64])
@pytest.mark.parametrize("free_margin_m", [0.0, 0.15])
def test_column_marks_equal_cell_marks(nz, free_margin_m):
    """Both kernels mark the same cells for 300 random rays (no exact boundary ties)."""
    rng = np.random.default_rng(nz)
    shape = (12, 9, nz)
    geometry = (*ORIGIN, CELL, LAYER)
    extent = np.array([shape[0] * CELL, shape[1] * CELL, nz * LAYER])
    for _ in range(5):
        sensor = np.array(ORIGIN) + rng.uniform(-0.3, 1.3, 3) * extent
        points = np.array(ORIGIN) + rng.uniform(-0.1, 1.1, (300, 3)) * extent
        fast = traversed_cells(points, sensor, geometry, shape, free_margin_m, columns=True)
        slow = traversed_cells(points, sensor, geometry, shape, free_margin_m, columns=False)
        assert np.array_equal(fast[0], slow[0]) and np.array_equal(fast[1], slow[1])
        assert len(fast[0]) > 0


def test_tall_grid_uses_cell_marks_and_matches_brute_force():
    """nz > 64 does not fit a column word: the per-cell kernel runs, rays still exact."""
    params = MapperParams(nx=10, ny=10, nz=80, layer_m=0.01, free_margin_m=0.0)
    m = FloorObstacleMapper(params)
    assert not m._columns
    with pytest.raises(InvalidParameterError, match="nz <= 64"):
        FloorObstacleMapper(params, column_marks=True)
    sensor = np.array([0.0, 0.0, 0.5])  # grid z spans [-0.06, 0.74)
    point = np.array([[0.15, 0.05, 0.015]])
    m.update(point, [np.nan], sensor)
    levels = m.occupancy_levels()
    cell, valid = m.cell_of(point)
    assert valid[0] and cell[0, 2] == 7  # (0.015 + 0.06) / 0.01 = 7.5
    assert levels[tuple(cell[0])] == 179
    g = m.geometry
    miss, _ = traversed_cells(
        point, sensor, (*g.origin_xy_m, g.z_min_m, g.cell_m, g.layer_m), levels.shape
    )
    assert np.array_equal(np.flatnonzero(levels.reshape(-1) == 77), miss)
    assert len(miss) > 50  # 50 layers down and 4 columns across


def test_mapper_same_map_with_column_or_cell_marks():
    """Ten frames of the boxes scene: both mark kinds give the same levels, floor and FOG."""
    rays = camera_rays_world(PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0), 0.0, 25.0)
    boxes = [Box((1.0, 0.2), (0.3, 0.3, 0.07)), Box((0.8, -0.4), (0.2, 0.2, 0.3), walkable=False)]
    rng = np.random.default_rng(3)
    fast, slow = FloorObstacleMapper(column_marks=True), FloorObstacleMapper(column_marks=False)
    for i in range(10):
        camera = np.array([0.01 * i, 0.003 * i, 0.7])
        points, heights = cast_frame(camera, rays, boxes, noise_z_m=0.005, rng=rng)
        a, b = fast.update(points, heights, camera), slow.update(points, heights, camera)
        assert a == b
    assert np.array_equal(fast.occupancy_levels(), slow.occupancy_levels())
    assert np.array_equal(fast.floor(), slow.floor(), equal_nan=True)
    assert np.array_equal(fast.fog()[0], slow.fog()[0])
    assert a.cells_updated > 5000  # the check above compared real work
