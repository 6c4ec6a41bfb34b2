"""Unconfirmed floors (`MapperParams.min_floor_frames`, `mapper.fog.mark_unconfirmed_floors`).

A cell the FOG labels floor whose stored floor holds fewer than ``min_frames`` frame votes is
unknown when no neighbour holds a floor within the band of it with ``min_frames`` votes and two
opposite neighbours hold no floor and an obstacle top no lower than ``eps`` below it. By hand on
a 3 × 3 grid (the centre judged), then through the mapper: a rough top's level patch seen as a
plane by the last frame only.
"""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.fog import mark_unconfirmed_floors

F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN
BAND, EPS = 0.02, 0.01
PATCH_M, TOP_M = 0.185, 0.22  # a level patch of a rough top, and the top's column top
N = np.nan


def judge(floors, tops, votes, min_frames=2):
    """Label of the centre of a 3 × 3 grid (rows x, columns y) with these stored floors (NaN:
    none), obstacle tops and frame votes; the centre is labelled floor, the others obstacle."""
    floor, obstacle = np.array(floors, dtype=float), np.array(tops, dtype=float)
    votes_grid = np.array(votes, dtype=np.int32)
    types = np.full((3, 3), np.int8(OB))
    types[1, 1] = F
    heights = obstacle.copy()
    heights[1, 1] = floor[1, 1]
    changed = mark_unconfirmed_floors(
        floor, obstacle, votes_grid, types, heights, min_frames, BAND, EPS, 0, 3, 0, 3
    )
    assert changed == (types[1, 1] == U)
    assert (types[1, 1] == U) == np.isnan(heights[1, 1])
    return types[1, 1]


P, T = PATCH_M, TOP_M
INSIDE = ([[N, N, N], [N, P, N], [N, N, N]], [[T] * 3] * 3)  # a patch inside a rough top
ONE_VOTE = [[0, 0, 0], [0, 1, 0], [0, 0, 0]]


def test_a_one_frame_floor_inside_something_is_unknown():
    assert judge(*INSIDE, ONE_VOTE) == U
    # Two opposite cells suffice: north and south, or across a diagonal.
    assert judge([[P, N, P], [P, P, P], [P, N, P]], [[T] * 3] * 3, ONE_VOTE) == U
    assert judge([[N, P, P], [P, P, P], [P, P, N]], [[T] * 3] * 3, ONE_VOTE) == U


def test_a_floor_seen_by_two_frames_stays():
    assert judge(*INSIDE, [[0, 0, 0], [0, 2, 0], [0, 0, 0]]) == F
    assert judge(*INSIDE, [[0, 0, 0], [0, 2, 0], [0, 0, 0]], min_frames=3) == U


def test_a_confirmed_floor_of_its_height_beside_it_keeps_it():
    # A surface growing at the edge of the view: the new cell beside a confirmed one.
    floors = [[N, P + 0.015, N], [N, P, N], [N, N, N]]
    assert judge(floors, [[T] * 3] * 3, [[0, 2, 0], [0, 1, 0], [0, 0, 0]]) == F
    # Not of its height (more than the band off), or not confirmed: no help.
    floors = [[N, P + 0.025, N], [N, P, N], [N, N, N]]
    assert judge(floors, [[T] * 3] * 3, [[0, 5, 0], [0, 1, 0], [0, 0, 0]]) == U
    floors = [[N, P, N], [N, P, N], [N, N, N]]
    assert judge(floors, [[T] * 3] * 3, [[0, 1, 0], [0, 1, 0], [0, 0, 0]]) == U


def test_a_floor_at_the_edge_of_something_stays():
    # Beside a riser or a wall (row 0) with its own surface on the other side (row 2, one
    # frame too): no opposite pair.
    assert judge([[N, N, N], [P, P, P], [P, P, P]], [[T] * 3] * 3, ONE_VOTE) == F


def test_nothing_reaching_its_level_leaves_it():
    # A column reaching the floor's level from below (a crest of a rough top) counts; a lower
    # one (a drop), or nothing stored at all, does not.
    assert judge(INSIDE[0], [[P - EPS] * 3] * 3, ONE_VOTE) == U
    assert judge(INSIDE[0], [[P - EPS - 0.005] * 3] * 3, ONE_VOTE) == F
    assert judge(INSIDE[0], [[N] * 3] * 3, ONE_VOTE) == F


def test_cells_outside_the_window_and_labels_not_floor_are_left():
    floor = np.array([[N, N, N], [P, P, P], [N, N, N]])
    obstacle = np.full((3, 3), T)
    votes = np.ones((3, 3), dtype=np.int32)
    types = np.full((3, 3), np.int8(F))
    types[1, 2] = OB
    heights = np.full((3, 3), P)
    # Window: row 1 only, between rows 0 and 2 (no floor, a top above). (1, 0) and (1, 1)
    # become unknown; (1, 2) has no floor label; rows 0 and 2 lie outside the window.
    changed = mark_unconfirmed_floors(
        floor, obstacle, votes, types, heights, 2, BAND, EPS, 1, 2, 0, 3
    )
    assert changed == 2
    assert types.tolist() == [[F, F, F], [U, U, OB], [F, F, F]]


def _frame(patch_is_floor, centre):
    """Points of one frame [m]: ground around a 0.24 m box whose top's points lie at 0.20 m
    (not floor), but for the 4 cm column of the cell centred at ``centre`` at `PATCH_M` —
    floor points at their plane's height when ``patch_is_floor``, else points that are not
    floor. Returns points, floor heights."""
    cx, cy = centre
    xs, ys = np.meshgrid(
        np.arange(cx - 0.395, cx + 0.4, 0.01), np.arange(cy - 0.395, cy + 0.4, 0.01), indexing="ij"
    )
    xs, ys = xs.ravel(), ys.ravel()
    on_box = (np.abs(xs - cx) < 0.12) & (np.abs(ys - cy) < 0.12)
    patch = (np.abs(xs - cx) < 0.02) & (np.abs(ys - cy) < 0.02)
    z = np.where(on_box, 0.20, 0.0)
    z[patch] = PATCH_M
    heights = np.where(on_box, np.nan, 0.0)
    if patch_is_floor:
        heights[patch] = PATCH_M
    return np.column_stack([xs, ys, z]), heights


@pytest.mark.parametrize("min_frames", [0, 2])
def test_the_last_frames_patch_on_a_rough_top(min_frames):
    """Ten frames see the box top as no plane; the last sees one column's level patch as a
    floor. Without the rule it is a floor (the frames that would take it away never come);
    with it, unknown — until a second frame sees the same plane there. The ground is a floor
    either way, seen by every frame."""
    mapper = FloorObstacleMapper(MapperParams(min_floor_frames=min_frames))
    (ix, iy), (gx, gy) = mapper.cell_of(np.array([[0.6, 0.0], [0.3, 0.0]]))[0]
    centre = mapper.cell_center(ix, iy)
    camera = np.array([0.0, 0.0, 1.5])
    for _ in range(10):
        mapper.update(*_frame(False, centre), camera)
    mapper.update(*_frame(True, centre), camera)
    types, heights = mapper.fog()
    assert np.isclose(mapper.floor()[ix, iy], PATCH_M)
    assert types[gx, gy] == F
    assert types[ix, iy] == (U if min_frames == 2 else F)
    mapper.update(*_frame(True, centre), camera)
    types, heights = mapper.fog()
    assert types[ix, iy] == F and np.isclose(heights[ix, iy], PATCH_M)


def test_parameter_checks():
    assert MapperParams().min_floor_frames == 2
    with pytest.raises(InvalidParameterError, match="min_floor_frames"):
        MapperParams(min_floor_frames=-1)
    with pytest.raises(InvalidParameterError, match="min_floor_frames"):
        MapperParams(min_floor_frames=5, floor_frame_cap=4)
    MapperParams(min_floor_frames=5, floor_frame_cap=0)  # votes off: the rule is off
