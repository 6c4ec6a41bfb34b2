"""Floor verification (eq. 8) and floor update (eq. 9) on hand-made grids."""

import numpy as np
import pytest

from mapper import MapperParams
from mapper.floor_map import LEVEL_MIN_POINTS, frame_verdicts, update_floor, verify_floor

# The hand values below are for these thresholds (the defaults before tuning, see MapperParams).
P = MapperParams(
    p_occ=0.75, eps_m=0.02, nu=0.9, p_sense=0.7, p_min=0.12, p_max=0.97
)  # occupied iff level > 192; z_min -0.06
OCC, FREE = 230, 60
Z0, L = P.z_min_m, P.layer_m


def layer_of(h):
    return int(np.floor((h - Z0) / L))


def grids(nx=4, ny=3):
    og = np.full((nx, ny, P.nz), 128, dtype=np.uint8)
    floor = np.full((nx, ny), np.nan)
    return og, floor


def run_update(floor, og, cols, heights, vote_cap=0, votes=None):
    """Eq. 9 for points in cells ``cols``; ``vote_cap`` 0 = the paper's rule."""
    ny = og.shape[1]
    point_cell = np.array([ix * ny + iy for ix, iy in cols], dtype=np.int64)
    return update_floor(
        floor,
        np.zeros(floor.shape, dtype=np.int32) if votes is None else votes,
        np.zeros(floor.shape, dtype=np.int32),
        og,
        point_cell,
        np.asarray(heights, dtype=float),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
        vote_cap,
    )


def test_eq8_keeps_supported_and_invalidates_unsupported_floor():
    og, floor = grids()
    floor[0, 0] = floor[1, 0] = floor[2, 0] = 0.10
    og[0, 0, layer_of(0.10)] = OCC  # still supported
    og[1, 0, layer_of(0.10)] = FREE  # cleared
    og[2, 0, layer_of(0.10)] = 192  # exactly p_occ: not above it
    og[3, 0, layer_of(0.10)] = FREE  # outside the affected area below
    floor[3, 0] = 0.10
    removed = verify_floor(floor, og, P.occ_threshold_level, Z0, L, 0, 3, 0, 3)
    assert removed == 2
    assert floor[0, 0] == 0.10
    assert np.isnan(floor[1, 0]) and np.isnan(floor[2, 0])
    assert floor[3, 0] == 0.10  # not in [0, 3) x [0, 3): untouched


def test_eq8_floor_outside_z_range_is_unsupported():
    og, floor = grids()
    floor[0, 0] = P.z_max_m + 0.01
    verify_floor(floor, og, P.occ_threshold_level, Z0, L, 0, 1, 0, 1)
    assert np.isnan(floor[0, 0])


@pytest.mark.parametrize(
    ("stored", "h", "expected"),
    [
        (np.nan, 0.10, 0.10),  # invalid -> h
        (0.10, 0.13, 0.13),  # h > F + eps: a higher surface replaces it
        (0.10, 0.07, 0.10),  # h < F - eps: lower surface ignored
        (0.10, 0.11, 0.9 * 0.10 + 0.1 * 0.11),  # |h - F| <= eps: smoothing
        (0.10, 0.085, 0.9 * 0.10 + 0.1 * 0.085),
    ],
)
def test_eq9_four_cases(stored, h, expected):
    og, floor = grids()
    floor[1, 2] = stored
    og[1, 2, :] = OCC
    used, rejected = run_update(floor, og, [(1, 2)], [h])
    assert (used, rejected) == (1, 0)
    assert floor[1, 2] == pytest.approx(expected, abs=1e-12)


def test_eq7_rejects_points_whose_cell_is_not_occupied():
    og, floor = grids()
    floor[0, 0] = 0.10
    og[0, 0, layer_of(0.20)] = 150  # below p_occ
    og[0, 1, layer_of(0.20)] = OCC
    used, rejected = run_update(floor, og, [(0, 0), (0, 1)], [0.20, 0.20])
    assert (used, rejected) == (1, 1)
    assert floor[0, 0] == 0.10 and floor[0, 1] == 0.20


def test_not_floor_and_dropped_points_are_ignored():
    og, floor = grids()
    og[:] = OCC
    point_cell = np.array([-1, -2, 0], dtype=np.int64)
    used, rejected = update_floor(
        floor,
        np.zeros(floor.shape, dtype=np.int32),
        np.zeros(floor.shape, dtype=np.int32),
        og,
        point_cell,
        np.array([0.1, 0.1, np.nan]),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
        64,
    )
    assert (used, rejected) == (0, 0)
    assert np.all(np.isnan(floor))


def test_points_apply_in_order():
    og, floor = grids()
    og[:] = OCC
    run_update(floor, og, [(0, 0)] * 3, [0.0, 0.01, 0.05])
    # 0.0 -> 0.0; 0.01 within eps -> 0.001; 0.05 > 0.001 + eps -> 0.05
    assert floor[0, 0] == pytest.approx(0.05)
    og2, floor2 = grids()
    og2[:] = OCC
    run_update(floor2, og2, [(0, 0)] * 3, [0.05, 0.0, 0.01])
    assert floor2[0, 0] == pytest.approx(0.05)  # the lower surface never replaces the higher


# ---------------------------------------------------------------- votes (beyond the paper)
# eps 0.02 and nu 0.9 (P); a lower tread at 0.031 m, the next one at 0.061 m.
LOW, HIGH = 0.031, 0.061


def voted(heights, vote_cap):
    """Floor height and votes of one cell after ``heights`` in order."""
    og, floor = grids()
    og[:] = OCC
    votes = np.zeros(floor.shape, dtype=np.int32)
    run_update(floor, og, [(0, 0)] * len(heights), heights, vote_cap, votes)
    return floor[0, 0], int(votes[0, 0])


def test_votes_a_stray_higher_point_does_not_take_the_cell():
    # Five points of the lower tread, then one of the higher tread carried over by noise: the
    # paper's rule (cap 0) takes the higher height for good, the votes keep the lower tread.
    assert voted([LOW] * 5 + [HIGH], 0)[0] == HIGH
    height, votes = voted([LOW] * 5 + [HIGH], 64)
    assert height == pytest.approx(LOW, abs=1e-15)  # smoothing a height with itself
    assert votes == 4


def test_votes_another_surface_replaces_when_no_vote_is_left():
    assert voted([LOW] * 3 + [HIGH] * 2, 64) == (pytest.approx(LOW, abs=1e-15), 1)
    assert voted([LOW] * 3 + [HIGH] * 3, 64) == (HIGH, 1)
    # the new surface then gathers votes like the old one: 0.9·HIGH + 0.1·HIGH
    assert voted([LOW] * 3 + [HIGH] * 4, 64) == (pytest.approx(HIGH, abs=1e-15), 2)


def test_votes_a_lower_surface_wins_back_a_cell_taken_by_a_stray_point():
    # A stray higher point first (1 vote), then the lower tread: the paper ignores it.
    assert voted([HIGH, LOW, LOW], 0)[0] == HIGH
    assert voted([HIGH, LOW, LOW], 64) == (pytest.approx(LOW, abs=1e-15), 2)


def test_votes_are_capped():
    # Ten agreeing points hold only 4 votes with cap 4: four points of another surface win.
    assert voted([LOW] * 10, 4)[1] == 4
    assert voted([LOW] * 10 + [HIGH] * 3, 4)[0] == pytest.approx(LOW, abs=1e-15)
    assert voted([LOW] * 10 + [HIGH] * 4, 4) == (HIGH, 1)
    assert voted([LOW] * 10 + [HIGH] * 4, 64)[1] == 6


def test_votes_within_eps_smooth_as_eq9():
    height, votes = voted([0.10, 0.11, 0.085], 64)
    assert height == pytest.approx(0.9 * (0.9 * 0.10 + 0.1 * 0.11) + 0.1 * 0.085, abs=1e-15)
    assert votes == 3


# ---------------------------------------------------------------- frame verdicts (beyond the paper)
TOP = 0.20  # a stored floor at 0.20 m in column (0, 0)


def verdict(frames, cap, frame_votes=1):
    """Floor and frame votes of column (0, 0) after ``frames`` of (z, h) point lists."""
    floor = np.full((2, 2), np.nan)
    floor[0, 0] = TOP
    votes = np.zeros((2, 2), dtype=np.int32)
    votes[0, 0] = frame_votes
    removed = 0
    for points in frames:
        z = np.array([p[0] for p in points], dtype=float)
        h = np.array([p[1] for p in points], dtype=float)
        cells = np.zeros(len(points), dtype=np.int64)
        removed += frame_verdicts(floor, votes, cells, z, h, P.eps_m, cap)
    return floor[0, 0], int(votes[0, 0]), removed


# No plane, at the floor's height and spread over more than eps (a rough top): 3 points at
# or below the floor count against it, one above it does not.
ROUGH = [(TOP - 0.015, np.nan), (TOP - 0.005, np.nan), (TOP, np.nan), (TOP + 0.008, np.nan)]
# No plane, level: 5 points within 10 mm (LEVEL_MIN_POINTS), 2 of them above the floor.
LEVEL = [(TOP + dz, np.nan) for dz in (-0.005, -0.002, 0.0, 0.002, 0.005)]
PLANE = [(TOP + 0.001, TOP + 0.001)] * 2


def test_frames_seeing_no_plane_remove_the_floor():
    # Votes 1, then one rough frame: gone. With 3 votes it takes three.
    assert np.isnan(verdict([ROUGH], 40)[0])
    assert verdict([ROUGH] * 2, 40, frame_votes=3)[:2] == (TOP, 1)
    height, _, removed = verdict([ROUGH] * 3, 40, frame_votes=3)
    assert np.isnan(height) and removed == 1


def test_frames_seeing_the_plane_add_votes_up_to_the_cap():
    assert verdict([PLANE] * 10, 4)[:2] == (TOP, 4)
    assert verdict([PLANE] * 10 + [ROUGH] * 3, 4)[:2] == (TOP, 1)
    assert np.isnan(verdict([PLANE] * 10 + [ROUGH] * 4, 4)[0])


def test_only_points_at_or_just_below_the_floor_count_against_it():
    # Points above the floor (a riser, a foot) or more than eps below (a lower tread) and
    # floor points of another height say nothing; the majority decides within one frame.
    above = [(TOP + 0.002, np.nan)] * 5
    below = [(TOP - P.eps_m - 0.001, np.nan)] * 5
    other = [(0.10, 0.10)] * 5
    assert verdict([above, below, other], 40)[:2] == (TOP, 1)
    assert np.isnan(verdict([ROUGH + PLANE], 40)[0])  # 3 against 2
    assert verdict([ROUGH[:2] + PLANE], 40)[:2] == (TOP, 2)  # 2 against 2: a tie is for it


def test_frames_seeing_the_floor_level_but_no_plane_say_nothing():
    # Points that are not floor but lie within eps of each other at the floor's height: the
    # segmentation found no plane in the region, this column looks like the floor.
    assert verdict([LEVEL] * 5, 40) == (TOP, 1, 0)
    assert verdict([LEVEL, PLANE, LEVEL, PLANE], 40)[:2] == (TOP, 3)
    assert verdict([[*LEVEL, (TOP - 0.012, np.nan)]], 40) == (TOP, 1, 0)  # 17 mm apart
    spread = [*LEVEL, (TOP - P.eps_m, np.nan)]  # 25 mm apart: rough
    assert np.isnan(verdict([spread], 40)[0])
    # Fewer points are level whatever the surface: they count against it as before.
    assert len(LEVEL) == LEVEL_MIN_POINTS
    assert np.isnan(verdict([LEVEL[:-1]], 40)[0])


def test_no_frame_verdicts_with_cap_zero():
    assert verdict([ROUGH] * 5, 0) == (TOP, 1, 0)
