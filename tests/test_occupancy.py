"""8-bit Bayes tables and exact ray insertion, against hand-computed values and brute force."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mapper import FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.errors import InvalidParameterError
from mapper.occupancy import (
    NONFINITE,
    OUTSIDE,
    _apply_columns,
    _clamped_cell,
    _lowest_bit,
    _range_mask,
    bayes_update,
    grid_point,
    layer_range_masks,
    lookup_tables,
    traversed_cells,
    update_table,
)
from mapper.synthetic import Box, camera_rays_world, cast_frame

# The hand-computed levels below are for the sensor model these were worked out with.
HAND = {"p_sense": 0.7, "p_min": 0.12, "p_max": 0.97}


def test_tables_by_hand():
    # p_sense = 0.7, p = L/256, clamps 0.12 (level 31) and 0.97 (level 248).
    hit, miss = lookup_tables(MapperParams(**HAND))
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


def test_layer_range_masks_by_hand():
    """Flat rows of 64: entry a*64 + b holds layers min(a, b) … max(a, b), either order."""
    masks = layer_range_masks(4)
    assert masks.dtype == np.uint8 and masks.shape == (4 * 64,)
    assert masks[1 * 64 + 3] == masks[3 * 64 + 1] == 0b1110
    assert masks[2 * 64 + 2] == 0b0100
    assert masks[0 * 64 + 3] == 0b1111
    assert not masks[[a * 64 + b for a in range(4) for b in range(4, 64)]].any()
    assert _range_mask(masks, 3, 0) == 0b1111 and _range_mask(masks, 1, 2) == 0b0110
    tall = layer_range_masks(64)
    assert tall.dtype == np.uint64 and tall[0 * 64 + 63] == np.uint64(2**64 - 1)
    assert tall[63 * 64 + 62] == np.uint64(3 << 62)


def test_lowest_bit_every_position():
    """The De Bruijn lookup finds the lowest set bit of any word, whatever the bits above it."""
    for k in range(64):
        low = np.uint64(1) << np.uint64(k)
        above = np.uint64(0xFFFF_FFFF_FFFF_FFFF) << np.uint64(k)  # k and every bit above it
        for word in (low, above, low | (above & np.uint64(0xA5A5_A5A5_A5A5_A5A5))):
            bit, index = _lowest_bit(word)
            assert (int(bit), int(index)) == (1 << k, k)


@pytest.mark.parametrize("nz", [4, 16, 64])
def test_apply_columns_updates_exactly_the_marked_layers(nz):
    """Hit where a hit bit is set (it wins over a miss), miss where only a miss bit is, else
    the level is kept; only the box is read, and its marks are cleared."""
    rng = np.random.default_rng(nz)
    nx, ny = 5, 7
    dtype = np.uint64 if nz == 64 else np.uint16 if nz == 16 else np.uint8
    levels = rng.integers(0, 256, size=(nx, ny, nz)).astype(np.uint8)
    bits = rng.random((2, nx * ny, nz)) < 0.3
    hit_cols, miss_cols = (
        np.array([sum(1 << k for k in np.flatnonzero(col)) for col in b], dtype=dtype) for b in bits
    )
    hit_table = ((np.arange(256) + 1) % 256).astype(np.uint8)
    miss_table = ((np.arange(256) + 255) % 256).astype(np.uint8)
    ix0, ix1, iy0, iy1 = 1, 3, 2, 6  # inclusive box
    inside = np.zeros((nx, ny), dtype=bool)
    inside[ix0 : ix1 + 1, iy0 : iy1 + 1] = True
    hit = bits[0].reshape(nx, ny, nz) & inside[:, :, None]
    miss = bits[1].reshape(nx, ny, nz) & inside[:, :, None] & ~hit
    expected = np.where(hit, hit_table[levels], np.where(miss, miss_table[levels], levels))
    outside = ~inside.reshape(-1)
    hit_before, miss_before = hit_cols.copy(), miss_cols.copy()
    flat = levels.reshape(-1)
    table = update_table(hit_table, miss_table)
    n = _apply_columns(flat, nz, ny, hit_cols, miss_cols, table, ix0, ix1, iy0, iy1)
    assert n == hit.sum() + miss.sum()
    np.testing.assert_array_equal(levels, expected)
    assert not hit_cols[~outside].any() and not miss_cols[~outside].any()
    np.testing.assert_array_equal(hit_cols[outside], hit_before[outside])
    np.testing.assert_array_equal(miss_cols[outside], miss_before[outside])


def test_tables_monotone_and_never_stall():
    p = MapperParams(p_sense=0.52)  # weak model: rounding alone would stall near the clamps
    hit, miss = lookup_tables(p)
    levels = np.arange(p.level_min, p.level_max + 1)
    assert np.all(hit[levels[:-1]] > levels[:-1])
    assert np.all(miss[levels[1:]] < levels[1:])
    assert np.all(np.diff(hit.astype(int)) >= 0) and np.all(np.diff(miss.astype(int)) >= 0)


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ((0.0, -0.0, 0.0), (0, 8, 8, 2)),  # cell faces: x = 0 opens cell 8; -0.0 is 0
        ((-1e-9, -0.25, -0.000001), (0, 7, 7, 1)),  # just below a face: the cell before it
        ((-2.0, 1.999, 0.999), (0, 0, 15, 3)),  # the grid's first and last cells
        ((-2.1, 0.0, 0.0), (OUTSIDE, -1, 8, 2)),  # below the -x face: -0.4 rounds down to -1
        ((2.0, 0.0, 0.0), (OUTSIDE, 16, 8, 2)),  # x = 2 m is the face after cell 15
        ((0.0, 0.0, -1.0000001), (OUTSIDE, 8, 8, -1)),
        ((np.nan, 0.0, 0.0), (NONFINITE, 0, 0, 0)),
        ((0.0, np.inf, 0.0), (NONFINITE, 0, 0, 0)),
    ],
)
def test_grid_point_cells_by_hand(point, expected):
    """16 x 16 x 4 cells of 0.25 m x 0.5 m from (-2, -2, -1) (binary-exact): floor of the
    grid units, also below zero (a point just outside the low faces is outside)."""
    status, _, _, _, ix, iy, iz = grid_point(*point, -2.0, -2.0, -1.0, 0.25, 0.5, 16, 16, 4)
    assert (status, ix, iy, iz) == expected


@pytest.mark.parametrize(
    ("v", "cell"),
    [
        (-3.5, 0),  # below the grid: the first cell
        (-0.25, 0),  # truncation would give 0 too, floor -1: clamped either way
        (0.0, 0),
        (2.999, 2),
        (3.0, 3),  # the last cell's low face
        (3.5, 3),
        (4.0, 3),  # the grid's far face: clamped into the last cell
        (1e20, 3),  # beyond int64: clamped before the conversion, no overflow
    ],
)
def test_clamped_cell_by_hand(v, cell):
    """Entry, exit and stop cells of a 4-cell axis: floor of the grid unit, clamped to 0..3."""
    assert _clamped_cell(v, 4) == cell


def test_bayes_update_matches_eq6():
    assert bayes_update(0.5, 0.7) == pytest.approx(0.7)
    assert bayes_update(0.7, 0.7) == pytest.approx(0.49 / (0.49 + 0.09))


PAPER = MapperParams(**HAND, free_margin_m=0.0)  # rays clear every cell before the end cell
CLEAR = MapperParams(**HAND, free_margin_m=0.0, clear_outside=True)  # and rays of no-hit ends clear


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
    m, sensor, point = _one_ray_mapper(MapperParams(**HAND, free_margin_m=0.08))
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


# ---------------------------------------------------------------- ends with no hit
def test_end_outside_in_x_clears_to_the_grid_face():
    """Sensor in cell (50, 50, 2), end at x = 2.5 m (grid x ends at 2.0): cells 50…99 cleared."""
    m, sensor, _ = _one_ray_mapper(CLEAR)
    r = m.update(np.array([[2.5, 0.02, 0.04]]), [np.nan], sensor)
    levels = m.occupancy_levels()
    assert np.all(levels[50:100, 50, 2] == 77)
    assert np.count_nonzero(levels != 128) == 50  # no hit anywhere
    assert (r.points_used, r.points_dropped_outside, r.points_beyond_range) == (0, 1, 0)
    assert r.affected_area.slices == (slice(50, 100), slice(50, 51))
    assert r.cells_updated == 50


@pytest.mark.parametrize(("end_x", "last_cleared"), [(2.5, 99), (2.02, 98)])
def test_end_outside_free_margin_from_the_true_end(end_x, last_cleared):
    """free_margin 0.08: end 0.5 m past the face -> all cleared; end at 2.02 -> stop at 1.94
    (cell (1.94 + 2) / 0.04 = 98.5 -> 98, cleared), cell 99 untouched."""
    m, sensor, _ = _one_ray_mapper(MapperParams(**HAND, free_margin_m=0.08, clear_outside=True))
    m.update(np.array([[end_x, 0.02, 0.04]]), [np.nan], sensor)
    levels = m.occupancy_levels()[:, 50, 2]
    assert np.all(levels[50 : last_cleared + 1] == 77)
    assert np.all(levels[last_cleared + 1 :] == 128)


def test_end_below_and_above_the_grid():
    """Straight down from above the grid to z = -0.5 (below z_min): the whole column cleared;
    a ray from above the grid to a point above it changes nothing."""
    m = FloorObstacleMapper(CLEAR)
    r = m.update(np.array([[0.02, 0.02, -0.5]]), [np.nan], np.array([0.02, 0.02, 1.0]))
    assert np.all(m.occupancy_levels()[50, 50] == 77)
    assert r.cells_updated == 16 and r.points_dropped_outside == 1
    r = m.update(np.array([[1.0, 1.0, 0.7]]), [np.nan], np.array([0.02, 0.02, 1.0]))
    assert r.affected_area is None and r.cells_updated == 0 and r.points_dropped_outside == 1


def test_max_range_truncates_the_ray_no_hit_no_floor():
    """End in cell 60 (x = 0.42) 0.40 m away, max_range 0.30: cleared to x = 0.32 (cell 58),
    no hit, no floor update even for a floor-labelled point."""
    m, sensor, point = _one_ray_mapper(CLEAR.with_overrides(max_range_m=0.30))
    r = m.update(point, [0.04], sensor)
    levels = m.occupancy_levels()
    assert np.all(levels[50:59, 50, 2] == 77)
    assert np.count_nonzero(levels != 128) == 9
    assert (r.points_used, r.points_dropped_outside, r.points_beyond_range) == (0, 0, 1)
    assert r.floor_points_used == 0 and np.all(np.isnan(m.floor()))
    # within range, the same point is a hit as before
    m2, _, _ = _one_ray_mapper(CLEAR.with_overrides(max_range_m=0.41))
    assert m2.update(point, [np.nan], sensor).points_used == 1
    assert m2.occupancy_levels()[60, 50, 2] == 179


def test_max_range_with_free_margin_stops_at_the_nearer():
    """End 0.40 m away, max_range 0.37, free_margin 0.08: stop at min(0.37, 0.32) -> x = 0.34
    (cell 58.5 -> 58); with free_margin 0.01: at 0.37 -> x = 0.39 (cell 59.75 -> 59)."""
    for margin, last in ((0.08, 58), (0.01, 59)):
        p = MapperParams(**HAND, free_margin_m=margin, max_range_m=0.37, clear_outside=True)
        m, sensor, point = _one_ray_mapper(p)
        m.update(point, [np.nan], sensor)
        levels = m.occupancy_levels()[:, 50, 2]
        assert np.all(levels[50 : last + 1] == 77) and np.all(levels[last + 1 :] == 128)


def test_clear_outside_off_ignores_no_hit_points():
    m, sensor, point = _one_ray_mapper(MapperParams(**HAND, max_range_m=0.35, clear_outside=False))
    below = [[0.02, 0.02, -0.1]]  # 0.14 m straight down, below the grid (z_min -0.06)
    r = m.update(np.vstack([point, below]), [np.nan] * 2, sensor)  # point: 0.40 m away
    assert r.affected_area is None and r.cells_updated == 0
    assert (r.points_dropped_outside, r.points_beyond_range) == (1, 1)
    assert np.all(m.occupancy_levels() == 128)


@pytest.mark.parametrize("clear_outside", [True, False])
def test_border_cell_noise_cleared_by_rays_to_farther_points(clear_outside):
    """Two frames of noisy hits make border cell (99, 50, 2) occupied; rays through it to points
    beyond the grid then clear it (three frames of misses: 216 -> 179 -> 128 -> 77) — or not,
    with clear_outside off (the false obstacles on the grid border)."""
    p = MapperParams(**HAND, free_margin_m=0.0, clear_outside=clear_outside)
    m, sensor, _ = _one_ray_mapper(p)
    for _ in range(2):
        m.update(np.array([[1.98, 0.02, 0.04]]), [np.nan], sensor)
    assert m.occupancy_levels()[99, 50, 2] == 216  # > 192: occupied
    for _ in range(3):
        m.update(np.array([[2.6, 0.02, 0.04]]), [np.nan], sensor)
    level = m.occupancy_levels()[99, 50, 2]
    assert (level <= p.occ_threshold_level) == clear_outside
    assert level == (77 if clear_outside else 216)


# ---------------------------------------------------------------- brute-force reference
SHAPE = (7, 6, 5)
CELL, LAYER = 0.1, 0.07
ORIGIN = (-0.2, 0.3, -0.1)  # grid corner x, y and z_min


def _reference(sensor, end, t_max=1.0):
    """Cells whose box the segment sensor->end crosses with positive length (slab test).

    Only the part ``t <= t_max`` of the segment ``sensor + t·(end - sensor)`` counts.
    """
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
    t1 = np.minimum(t_out.min(axis=1), t_max)
    length = (t1 - t0) * np.linalg.norm(d)
    return length


coord = st.floats(-1.0, 1.5, allow_nan=False, allow_infinity=False)
# end positions as fractions of the grid's extent: inside, beside, above, below, far off
end_coord = st.one_of(st.floats(0, 0.999), st.floats(-1.5, 2.5))
max_range = st.one_of(st.just(np.inf), st.floats(0.05, 1.5))


def _expected_marks(sensor, end, free_margin_m, max_range_m):
    """(miss cells by brute force, hit cell or None, segment lengths per cell) of one ray."""
    extent = np.array([SHAPE[0] * CELL, SHAPE[1] * CELL, SHAPE[2] * LAYER])
    rel = end - np.array(ORIGIN)
    length = float(np.linalg.norm(end - sensor))
    inside = bool(np.all((rel >= 0) & (rel < extent)))
    hit_cell = None
    t_max = 1.0
    if length > max_range_m:  # beyond range: no hit, cleared up to the range
        t_max = max_range_m / length
    elif inside:
        cell = np.floor(rel / [CELL, CELL, LAYER]).astype(int)
        hit_cell = int(np.ravel_multi_index(tuple(np.minimum(cell, np.array(SHAPE) - 1)), SHAPE))
    if free_margin_m > 0:  # margin relative to the true end, the stop cell cleared
        t_max = min(t_max, 1.0 - free_margin_m / length)
    seg = _reference(sensor, end, t_max)
    return seg, hit_cell


@pytest.mark.parametrize("columns", [True, False], ids=["column-marks", "cell-marks"])
@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    sensor=st.tuples(coord, coord, coord),
    end_frac=st.tuples(end_coord, end_coord, end_coord),
    free_margin_m=st.sampled_from([0.0, 0.15]),
    max_range_m=max_range,
    clear_outside=st.booleans(),
)
def test_traversal_equals_brute_force(
    columns, sensor, end_frac, free_margin_m, max_range_m, clear_outside
):
    """Ends inside and outside the grid (beside, above, below, rays missing it), max range."""
    sensor = np.array(sensor)
    extent = np.array([SHAPE[0] * CELL, SHAPE[1] * CELL, SHAPE[2] * LAYER])
    end = np.array(ORIGIN) + np.array(end_frac) * extent
    miss, hit = traversed_cells(
        end[None],
        sensor,
        (*ORIGIN, CELL, LAYER),
        SHAPE,
        free_margin_m,
        columns=columns,
        max_range_m=max_range_m,
        clear_outside=clear_outside,
    )
    seg, hit_cell = _expected_marks(sensor, end, free_margin_m, max_range_m)
    assert hit.tolist() == ([] if hit_cell is None else [hit_cell])
    if hit_cell is None and not clear_outside:
        seg = np.zeros_like(seg)  # a no-hit end is ignored entirely
    expected = set(np.flatnonzero(seg > 1e-9).tolist()) - {hit_cell}
    got = set(miss.tolist())
    # cells the segment only grazes (numerically zero length) may go either way
    for cell in expected ^ got:
        assert seg[cell] < 1e-6, (cell, seg[cell])
    assert hit_cell not in got


def test_brute_force_draws_cover_outside_cases():
    """The end strategy draws ends beside, above and below the grid and rays missing it.

    (The same strategies and settings as the brute-force test, without its two extra axes.)
    """
    extent = np.array([SHAPE[0] * CELL, SHAPE[1] * CELL, SHAPE[2] * LAYER])
    seen = set()

    @settings(max_examples=400, deadline=None, derandomize=True, database=None)
    @given(sensor=st.tuples(coord, coord, coord), end_frac=st.tuples(*[end_coord] * 3))
    def classify(sensor, end_frac):
        end = np.array(ORIGIN) + np.array(end_frac) * extent
        frac = np.array(end_frac)
        if np.all((frac >= 0) & (frac < 1)):
            seen.add("inside")
        elif frac[2] >= 1 and np.all((frac[:2] >= 0) & (frac[:2] < 1)):
            seen.add("above")
        elif frac[2] < 0 and np.all((frac[:2] >= 0) & (frac[:2] < 1)):
            seen.add("below")
        else:
            seen.add("beside")
        if not np.any(_reference(np.array(sensor), end) > 1e-9):
            seen.add("misses")

    classify()
    assert seen == {"inside", "above", "below", "beside", "misses"}


@pytest.mark.parametrize("nz", [5, 16, 40, 64])
@pytest.mark.parametrize("free_margin_m", [0.0, 0.15])
@pytest.mark.parametrize("max_range_m", [np.inf, 1.0])
@pytest.mark.parametrize("clear_outside", [True, False])
def test_column_marks_equal_cell_marks(nz, free_margin_m, max_range_m, clear_outside):
    """Both kernels mark the same cells for 300 random rays (no exact boundary ties).

    Ends up to 60 % of the extent outside the grid on every side (no hit, rays clear).
    """
    rng = np.random.default_rng(nz)
    shape = (12, 9, nz)
    geometry = (*ORIGIN, CELL, LAYER)
    extent = np.array([shape[0] * CELL, shape[1] * CELL, nz * LAYER])
    marked = 0
    for _ in range(5):
        sensor = np.array(ORIGIN) + rng.uniform(-0.3, 1.3, 3) * extent
        points = np.array(ORIGIN) + rng.uniform(-0.6, 1.6, (300, 3)) * extent
        kw = {"max_range_m": max_range_m, "clear_outside": clear_outside}
        fast = traversed_cells(points, sensor, geometry, shape, free_margin_m, True, **kw)
        slow = traversed_cells(points, sensor, geometry, shape, free_margin_m, False, **kw)
        assert np.array_equal(fast[0], slow[0]) and np.array_equal(fast[1], slow[1])
        marked += len(fast[0])
    assert marked > 0  # the comparison saw cleared cells


def test_tall_grid_uses_cell_marks_and_matches_brute_force():
    """nz > 64 does not fit a column word: the per-cell kernel runs, rays still exact."""
    params = MapperParams(**HAND, nx=10, ny=10, nz=80, layer_m=0.01, free_margin_m=0.0)
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


@pytest.mark.parametrize("clear_outside", [True, False])
def test_map_inside_the_grid_does_not_depend_on_its_extent(clear_outside):
    """With clear_outside, a 4 m grid holds exactly the central part of a 6.4 m grid's map.

    A table top at 0.24–0.28 m, 0.8–1.2 m ahead, seen from 0.55 m (rays grazing over its far
    edge reach the ground 2.4 m ahead: beyond the 4 m grid, inside the 6.4 m one). Without
    clear_outside the small grid ignores those rays and keeps levels the larger grid clears.
    """
    rng = np.random.default_rng(3)
    rays = camera_rays_world(PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0), 0.0, 15.0)
    table = Box((1.0, 0.0), (0.4, 0.6, 0.04), base_m=0.24, walkable=False)
    small = FloorObstacleMapper(MapperParams(**HAND, clear_outside=clear_outside))
    large = FloorObstacleMapper(MapperParams(**HAND, nx=160, ny=160, clear_outside=clear_outside))
    for _ in range(10):
        camera = np.array([rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), 0.55])
        points, heights = cast_frame(camera, rays, [table], noise_z_m=0.003, rng=rng)
        a, b = small.update(points, heights, camera), large.update(points, heights, camera)
        assert a.points_dropped_outside > b.points_dropped_outside > 0
    centre = (slice(30, 130), slice(30, 130))  # origins -2.0 and -3.2 m: 30 cells apart
    same_levels = np.array_equal(small.occupancy_levels(), large.occupancy_levels()[centre])
    same_floor = np.array_equal(small.floor(), large.floor()[centre], equal_nan=True)
    same_fog = np.array_equal(small.fog()[0], large.fog()[0][centre])
    assert (same_levels and same_floor and same_fog) == clear_outside
