"""Floor verification (eq. 8) and floor update (eq. 9) on hand-made grids."""

import numpy as np
import pytest

from mapper import MapperParams
from mapper.floor_map import (
    ABOVE_RATIO,
    LEVEL_MIN_POINTS,
    frame_verdicts,
    update_floor,
    verify_floor,
)

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


def run_update(
    floor,
    og,
    cols,
    heights,
    vote_cap=0,
    votes=None,
    weights=None,
    memory=0.0,
    ranges=None,
    power=2.0,
):
    """Eq. 9 for points in cells ``cols``; ``vote_cap`` 0 = the paper's rule.

    ``memory`` 0 = the paper's smoothing by nu, else the weighted mean; the points lie
    ``ranges`` [m] (default 1) straight below a camera at the origin.
    """
    ny = og.shape[1]
    point_cell = np.array([ix * ny + iy for ix, iy in cols], dtype=np.int64)
    points = np.zeros((len(cols), 3))
    points[:, 2] = -np.ones(len(cols)) if ranges is None else -np.asarray(ranges, dtype=float)
    return update_floor(
        floor,
        np.zeros(floor.shape) if weights is None else weights,
        np.zeros(floor.shape, dtype=np.int32) if votes is None else votes,
        np.zeros(floor.shape, dtype=np.int32),
        og,
        point_cell,
        points,
        np.asarray(heights, dtype=float),
        np.zeros(3),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
        vote_cap,
        memory,
        power,
        P.delta_m,
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
        np.zeros(floor.shape),
        np.zeros(floor.shape, dtype=np.int32),
        np.zeros(floor.shape, dtype=np.int32),
        og,
        point_cell,
        np.zeros((3, 3)),
        np.array([0.1, 0.1, np.nan]),
        np.array([0.0, 0.0, 1.0]),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
        64,
        16.0,
        2.0,
        P.delta_m,
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


# ------------------------------------------------------------- a surface above (beyond the paper)
# eps 0.02, layers of 0.04 from z_min −0.06 (P): the ground 0.0 lies in layer 1 [−0.02, 0.02),
# a sill top at 0.045 in layer 2 [0.02, 0.06).
GROUND, SILL = 0.0, 0.045


def covered(points, vote_cap=64, votes=3, occupied=(GROUND, SILL)):
    """Floor height and votes of cell (0, 0), ground stored with ``votes``, after ``points``.

    ``points`` are (z, h) in order, ``h`` NaN = not floor; the layers of the heights in
    ``occupied`` are occupied, the others unknown (0.5).
    """
    og, floor = grids()
    for z in occupied:
        og[0, 0, layer_of(z)] = OCC
    floor[0, 0] = GROUND
    votes_grid = np.zeros(floor.shape, dtype=np.int32)
    votes_grid[0, 0] = votes
    z = np.array([p[0] for p in points], dtype=float)
    points_world = np.zeros((len(points), 3))
    points_world[:, 2] = z
    update_floor(
        floor,
        np.zeros(floor.shape),
        votes_grid,
        np.zeros(floor.shape, dtype=np.int32),
        og,
        np.zeros(len(points), dtype=np.int64),
        points_world,
        np.array([p[1] for p in points], dtype=float),
        np.array([0.0, 0.0, 1.0]),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
        vote_cap,
        0.0,
        2.0,
        P.delta_m,
    )
    return floor[0, 0], int(votes_grid[0, 0])


TOP_POINT = (SILL, np.nan)  # a point of the sill's top that is not floor
SILL_FLOOR = (SILL, SILL)  # one that is


def test_points_of_a_surface_above_take_the_stored_floors_votes():
    # The ground holds 3 votes; 3 points on the sill's top (not floor) take them all, but do not
    # replace it (they have no plane height): the sill's first floor point then does.
    assert covered([TOP_POINT] * 2) == (GROUND, 1)
    assert covered([TOP_POINT] * 3) == (GROUND, 0)
    assert covered([TOP_POINT] * 3 + [SILL_FLOOR]) == (SILL, 1)
    # Without them the sill's floor point only takes one vote away (3 → 2).
    assert covered([SILL_FLOOR]) == (GROUND, 2)
    # Votes never go below 0; a ground point gives one back, the sill's floor point takes it.
    assert covered([TOP_POINT] * 5) == (GROUND, 0)
    assert covered([TOP_POINT] * 3 + [(0.001, 0.001), SILL_FLOOR]) == (SILL, 1)


def test_a_column_seen_partly_at_the_floor_keeps_its_votes():
    # A riser inside the cell at a step's edge: points at the floor's height (floor points by
    # their plane's height, others by z) and above it. Those above (with floor points of a
    # higher surface) must be more than ABOVE_RATIO (2) times those at the floor to take votes.
    assert ABOVE_RATIO == 2
    at_floor = [(0.0, np.nan), (0.001, 0.001)]  # 2 at the floor, 1 of them a floor point
    assert covered([TOP_POINT] * 4 + at_floor)[1] == 4  # 4 ≤ 2·2: none taken, + 1
    assert covered([TOP_POINT] * 5 + at_floor)[1] == 1  # 5 > 4: 3 − 5 → 0, + 1
    # A floor point of a higher surface counts with those above and takes its own vote in
    # eq. 9's loop. 3 + 1 ≤ 4: 3, + 1 for the ground's floor point (0.1·0.001), − 1 for the
    # sill's. 4 + 1 > 4: 3 − 4 → 0, + 1, − 1: the sill takes the cell.
    assert covered([TOP_POINT] * 3 + at_floor + [SILL_FLOOR]) == (pytest.approx(0.0001), 3)
    assert covered([TOP_POINT] * 4 + at_floor + [SILL_FLOOR]) == (SILL, 1)


def test_only_points_in_an_occupied_layer_above_the_floor_count_as_a_surface_above():
    # 0.019 is within eps of the ground and in its layer: the ground's own noise; 0.021 is
    # in layer 2, more than eps above it.
    assert covered([(0.019, np.nan)] * 3) == (GROUND, 3)
    assert covered([(0.021, np.nan)] * 3) == (GROUND, 0)
    # More than delta (eq. 11: 0.05) above the floor: the FOG shows an obstacle there anyway
    # (a box on the ground, its rough top taken for a plane in one frame): nothing.
    assert P.delta_m == 0.05
    assert covered([(0.051, np.nan)] * 3, occupied=(GROUND, 0.051)) == (GROUND, 3)
    assert covered([(0.05, np.nan)] * 3, occupied=(GROUND, 0.05)) == (GROUND, 0)
    # Layer 2 not occupied (one noisy frame): nothing.
    assert covered([TOP_POINT] * 3, occupied=(GROUND,)) == (GROUND, 3)
    # Below the floor, or floor points (their plane's height decides, as in eq. 9): nothing.
    assert covered([(-0.03, np.nan)] * 3, occupied=(GROUND, -0.03)) == (GROUND, 3)
    assert covered([(SILL, 0.001)] * 3) == (pytest.approx(0.0001 * (1 + 0.9 + 0.81)), 6)
    # The paper's rule (cap 0): no votes, nothing.
    assert covered([TOP_POINT] * 3, vote_cap=0, votes=0) == (GROUND, 0)


# ---------------------------------------------------------------- weighted mean (beyond the paper)
# eps 0.02 (P); heights within it of the stored floor are averaged, one weight per frame.


def averaged(frames, memory=16.0, vote_cap=64, power=2.0):
    """Floor height and weight of cell (0, 0) after ``frames``: lists of (height, range [m])."""
    og, floor = grids()
    og[:] = OCC
    votes = np.zeros(floor.shape, dtype=np.int32)
    weights = np.zeros(floor.shape)
    for points in frames:
        heights = [h for h, _ in points]
        ranges = [r for _, r in points]
        run_update(
            floor,
            og,
            [(0, 0)] * len(points),
            heights,
            vote_cap,
            votes,
            weights,
            memory,
            ranges,
            power,
        )
    return floor[0, 0], weights[0, 0]


def test_mean_of_frames_at_close_range():
    # Three frames of one point each within 1 m: the plain mean, weight 3 frames.
    height, weight = averaged([[(0.100, 0.8)], [(0.106, 1.0)], [(0.097, 0.5)]])
    assert height == pytest.approx((0.100 + 0.106 + 0.097) / 3, abs=1e-15)
    assert weight == 3.0


def test_a_frame_weighs_one_however_many_points_it_has():
    # Four points of one plane (one height) then one point: each frame counts once, (0.1 +
    # 0.106) / 2, where eq. 9 per point would give 0.9 * 0.1 + 0.1 * 0.106 = 0.1006.
    height, weight = averaged([[(0.100, 1.0)] * 4, [(0.106, 1.0)]])
    assert height == pytest.approx(0.103, abs=1e-15)
    assert weight == pytest.approx(2.0, abs=1e-15)


def test_farther_frames_weigh_less():
    # A frame at 2 m weighs (1/2)^2 = 0.25 with power 2, 0.0625 with power 4.
    height, weight = averaged([[(0.100, 1.0)], [(0.110, 2.0)]])
    assert height == pytest.approx(0.100 + 0.25 / 1.25 * 0.010, abs=1e-15)  # 0.102
    assert weight == pytest.approx(1.25, abs=1e-15)
    height, _ = averaged([[(0.100, 1.0)], [(0.110, 2.0)]], power=4.0)
    assert height == pytest.approx(0.100 + 0.0625 / 1.0625 * 0.010, abs=1e-15)
    # Power 0: every frame weighs one, whatever its range.
    assert averaged([[(0.100, 3.0)], [(0.110, 2.0)]], power=0.0)[0] == pytest.approx(0.105)


def test_a_frame_split_between_surfaces_weighs_its_share():
    # A stored 0.100 (one frame), then a frame with 3 points at 0.104 and one of a surface
    # 0.1 m higher (a vote away): the three carry 3/4 of a frame, 0.1 + 0.004 * 0.75 / 1.75.
    height, weight = averaged([[(0.100, 1.0)], [(0.104, 1.0)] * 3 + [(0.200, 1.0)]])
    assert height == pytest.approx(0.100 + 0.004 * 0.75 / 1.75, abs=1e-15)
    assert weight == pytest.approx(1.75, abs=1e-15)


def test_memory_caps_the_weight_so_the_map_follows_change():
    # Memory 2: the third frame of 0.100 leaves the weight at 2, so a fourth frame at 0.106
    # moves the height by a third (0.102) and a fifth by a third of the rest (0.1033).
    frames = [[(0.100, 1.0)]] * 3 + [[(0.106, 1.0)]]
    height, weight = averaged(frames, memory=2.0)
    assert height == pytest.approx(0.102, abs=1e-15)
    assert weight == 2.0
    height, _ = averaged([*frames, [(0.106, 1.0)]], memory=2.0)
    assert height == pytest.approx(0.102 + 0.004 / 3, abs=1e-15)


def test_a_higher_surface_replaces_the_mean_and_starts_its_own():
    # The paper's rule (cap 0): a point 30 mm higher replaces a floor of 10 frames; the new
    # surface's mean starts from it (weight 1), so the next frame gives the mean of the two.
    frames = [[(0.100, 1.0)]] * 10 + [[(0.130, 1.0)], [(0.136, 1.0)]]
    height, weight = averaged(frames, vote_cap=0)
    assert height == pytest.approx(0.133, abs=1e-15)
    assert weight == 2.0
    # With votes (cap 64): the 10 frames' 10 votes take 10 frames of the other surface; the
    # 10th replaces, the next two average in.
    height, weight = averaged([[(0.100, 1.0)]] * 10 + [[(0.130, 1.0)]] * 10 + [[(0.133, 1.0)]] * 2)
    assert height == pytest.approx(0.132, abs=1e-15)
    assert weight == 3.0


def test_lower_heights_beyond_eps_are_not_averaged():
    # 0.075 is 25 mm below 0.100 (> eps 20 mm): another surface, ignored by the mean.
    assert averaged([[(0.100, 1.0)], [(0.075, 1.0)]], vote_cap=0) == (0.100, 1.0)


def test_points_rejected_by_eq7_take_no_share_of_the_frame():
    # Cell (0, 0): 0.100 in an occupied layer, 0.300 in a free one (rejected by eq. 7): the
    # frame's one usable point carries the whole frame.
    og, floor = grids()
    og[0, 0, layer_of(0.100)] = OCC
    og[0, 0, layer_of(0.300)] = FREE
    floor[0, 0] = 0.104
    weights = np.full(floor.shape, 1.0)
    used, rejected = run_update(
        floor, og, [(0, 0), (0, 0)], [0.300, 0.100], 64, None, weights, 16.0
    )
    assert (used, rejected) == (1, 1)
    assert floor[0, 0] == pytest.approx(0.102, abs=1e-15)
    assert weights[0, 0] == 2.0


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


def test_a_ground_with_many_votes_gives_way_to_a_sill_seen_mostly_as_points_that_are_not_floor():
    # Through the mapper (default parameters): 10 frames see the ground in cell [0, 0.04)² (4
    # floor points a frame: 40 votes), then frames see a 45 mm sill top there: 4 points that
    # are not floor and 1 floor point a frame (the stage_zigzag sill on stereo). Its layer
    # [0.02, 0.06) is occupied from the 2nd frame (eq. 7: the 1st frame's floor point is
    # rejected); from then on each frame takes 5 votes: in the 9th the ground's 40 are gone and
    # the sill's floor point takes the cell. Before, the one floor point a frame took one vote:
    # 40 frames.
    from mapper import FloorObstacleMapper

    mapper = FloorObstacleMapper()
    origin = np.array([0.02, 0.02, 1.0])
    xy = np.array([[0.01, 0.01], [0.03, 0.01], [0.01, 0.03], [0.03, 0.03]])
    ground = np.column_stack([xy, np.zeros(4)])
    for _ in range(10):
        mapper.update(ground, np.zeros(4), origin)
    assert mapper.floor_at(0.02, 0.02) == 0.0
    sill = np.vstack([np.column_stack([xy, np.full(4, SILL)]), [0.02, 0.02, SILL]])
    sill_heights = np.array([np.nan] * 4 + [SILL])
    heights = []
    for _ in range(12):
        mapper.update(sill, sill_heights, origin)
        heights.append(mapper.floor_at(0.02, 0.02))
    assert heights[:8] == [0.0] * 8 and heights[8:] == [SILL] * 4
