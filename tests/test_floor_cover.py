"""The floor cover check (`mapper.floor_cover`): rays that reach a floor's height must end on it."""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.floor_cover import accumulate_cover, frame_floor_heights
from mapper.synthetic import Box, camera_rays_world, cast_frame

EPS = 0.01
CAMERA = np.array([0.0, 0.02, 1.0])


def counts(floor_m, points, heights, state=None):
    """One frame on a 3 x 1 grid of 4 cm cells from x = 0: (ref, ends, passes)."""
    floor = np.array(floor_m, dtype=float).reshape(3, 1)
    ref, ends, passes = state or (
        np.full((3, 1), np.nan),
        np.zeros((3, 1), dtype=np.int32),
        np.zeros((3, 1), dtype=np.int32),
    )
    pts = np.array(points, dtype=float)
    h = np.array(heights, dtype=float)
    cells = np.floor(pts[:, 0] / 0.04).astype(np.int64)
    accumulate_cover(
        floor, ref, ends, passes, cells, pts, h, CAMERA, frame_floor_heights(h, EPS), 0.0, 0.0,
        0.04, EPS,
    )  # fmt: skip
    return ref, ends, passes


def test_frame_floor_heights_merges_heights_within_eps():
    h = np.array([0.0304, np.nan, 0.0, 0.004, 0.03, 0.0301, 0.12])
    assert frame_floor_heights(h, EPS).tolist() == [0.0, 0.03, 0.12]


def test_frame_floor_heights_of_runs_as_in_a_frame():
    """Runs of one plane's height, interleaved and repeated, ±inf and NaN (not floor)."""
    h = np.array([np.nan, 0.03, 0.03, 0.0, 0.0, np.inf, 0.12, 0.12, 0.0, 0.009, 0.03, -np.inf])
    assert frame_floor_heights(h, EPS).tolist() == [0.0, 0.03, 0.12]  # 0.009 within eps of 0
    assert frame_floor_heights(np.full(4, np.nan), EPS).tolist() == []
    assert frame_floor_heights(np.array([0.05]), EPS).tolist() == [0.05]


def test_rays_ending_on_passing_through_and_stopping_short_of_a_floor_by_hand():
    points = [
        [0.06, 0.02, 0.10],  # a floor point on cell 1's floor: ends on it
        [0.07, 0.02, 0.0],  # crosses z = 0.10 at x = 0.9 * 0.07 = 0.063 (cell 1): passes
        [0.065, 0.02, 0.095],  # ends 5 mm below the floor (within eps): neither
        [0.10, 0.02, 0.0],  # crosses z = 0.10 at x = 0.09 (cell 2, no floor): nothing
    ]
    heights = [0.10, np.nan, np.nan, np.nan]
    ref, ends, passes = counts([np.nan, 0.10, np.nan], points, heights)
    assert ends.ravel().tolist() == [0, 1, 0]
    assert passes.ravel().tolist() == [0, 1, 0]
    assert ref[1, 0] == 0.10 and np.isnan(ref[[0, 2], 0]).all()


def test_counts_restart_when_another_surface_takes_the_cell():
    state = counts([np.nan, 0.10, np.nan], [[0.06, 0.02, 0.10]] * 3, [0.10] * 3)
    assert state[1][1, 0] == 3
    # the cell's floor is now 0.05 (another surface): one ray ends on it, one passes
    points = [[0.05, 0.02, 0.05], [0.07, 0.02, 0.0]]  # the second crosses 0.05 at x = 0.0665
    ref, ends, passes = counts([np.nan, 0.05, np.nan], points, [0.05, np.nan], state)
    assert (ref[1, 0], ends[1, 0], passes[1, 0]) == (0.05, 1, 1)


# ------------------------------------------------------------------ end to end
INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
RAYS = camera_rays_world(INTR, yaw_deg=0.0, pitch_down_deg=30.0)
# A 0.12 m tread: its front riser at x = 0.8 and its side edge at y = 0.0 lie on cell
# boundaries. Seen from y = -0.3, the ground just beyond the side edge is hidden behind it.
TREAD = Box((1.0, -0.3), (0.4, 0.6, 0.12))
SPILL_M = 0.012


def spilled_frame(rng, camera):
    """An exact frame whose tread points within 12 mm of its side edge / front riser are carried
    12 mm over it (registration error, the segmentation snapping riser points onto the tread)."""
    pts, h = cast_frame(camera, RAYS, [TREAD])
    on_top = h == TREAD.top_m
    side = on_top & (pts[:, 1] > -SPILL_M)
    front = on_top & (pts[:, 0] < 0.8 + SPILL_M)
    pts[side, 1] += SPILL_M
    pts[front, 0] -= SPILL_M
    return pts, h


def walk(params, rng):
    m = FloorObstacleMapper(params)
    for _ in range(30):  # a camera swaying by ±2 cm, as a walking robot's does
        camera = np.array([rng.uniform(0.0, 0.04), rng.uniform(-0.32, -0.28), 0.6])
        m.update(*spilled_frame(rng, camera), camera)
    return m


def cells(m, x_range, y_range):
    (ix0, iy0), (ix1, iy1) = m.cell_of([[x_range[0], y_range[0]], [x_range[1], y_range[1]]])[0]
    return slice(ix0, ix1 + 1), slice(iy0, iy1 + 1)


@pytest.mark.parametrize("fraction", [0.0, MapperParams().floor_pass_fraction])
def test_a_lower_surface_never_carries_the_spilled_tread_height(fraction):
    # The edge band off: it makes the rim and the hidden cells unknown whatever the cover
    # check says (tests/test_fog_margin.py).
    m = walk(MapperParams(floor_pass_fraction=fraction, edge_band_m=0.0), np.random.default_rng(4))
    types, heights = m.fog()
    beside = cells(m, (0.86, 1.14), (0.01, 0.03))  # hidden ground beside the side edge
    before = cells(m, (0.77, 0.79), (-0.5, -0.1))  # seen ground before the front riser
    taken = [
        (types[sl] == CellType.FLOOR) & np.isclose(heights[sl], TREAD.top_m)
        for sl in (beside, before)
    ]
    if fraction == 0.0:  # the paper's map: the spill takes the hidden cells
        assert taken[0].mean() > 0.5
    else:
        assert not taken[0].any() and not taken[1].any()
    # the tread's inside and the ground around are floor at their heights either way
    top = cells(m, (0.86, 1.14), (-0.5, -0.05))
    assert np.all(types[top] == CellType.FLOOR) and np.allclose(heights[top], 0.12)
    ground = cells(m, (0.6, 0.7), (-0.5, -0.1))
    assert np.all(types[ground] == CellType.FLOOR) and np.allclose(heights[ground], 0.0)


def test_a_riser_on_a_cell_boundary_leaves_both_cells_floor():
    """Exact data, no spill: every cell on either side of the riser keeps its floor.

    The FOG's obstacle margin and edge band are off: with the margin the cells at the riser's
    foot are obstacles, with the band the riser's rim cells unknown, whatever the cover check
    says (`tests/test_fog_margin.py`).
    """
    rng = np.random.default_rng(5)
    riser = Box((1.0, 0.0), (0.4, 0.8, 0.03))  # front edge at x = 0.8, a cell boundary
    m = FloorObstacleMapper(MapperParams(obstacle_margin_cells=0, edge_band_m=0.0))
    for _ in range(30):
        camera = np.array([rng.uniform(0.0, 0.04), rng.uniform(-0.02, 0.02), 0.6])
        pts, h = cast_frame(camera, RAYS, [riser])
        m.update(pts, h, camera)
    types, heights = m.fog()
    lower = cells(m, (0.70, 0.79), (-0.3, 0.3))
    upper = cells(m, (0.81, 0.9), (-0.3, 0.3))
    assert np.all(types[lower] == CellType.FLOOR) and np.allclose(heights[lower], 0.0)
    assert np.all(types[upper] == CellType.FLOOR) and np.allclose(heights[upper], 0.03)


@pytest.mark.parametrize(
    ("field", "value"),
    [("floor_pass_fraction", 1.0), ("floor_pass_fraction", -0.1), ("floor_pass_min_rays", 0)],
)
def test_bad_parameters_are_named(field, value):
    with pytest.raises(ValueError, match=field):
        MapperParams(**{field: value})


def test_counts_scroll_with_the_grid():
    """After a recenter the counts stay with their world cells (a hidden cell stays judged)."""
    m = walk(MapperParams(), np.random.default_rng(4))
    beside = cells(m, (0.86, 1.14), (0.01, 0.03))
    types_before = m.fog()[0][beside].copy()
    m.recenter(0.4, -0.2)  # a whole number of cells: 10 along x, 5 along y
    camera = np.array([0.02, -0.3, 0.6])
    m.update(*spilled_frame(None, camera), camera)
    after = cells(m, (0.86, 1.14), (0.01, 0.03))
    assert not np.any(types_before == CellType.FLOOR)
    assert not np.any(m.fog()[0][after] == CellType.FLOOR)
