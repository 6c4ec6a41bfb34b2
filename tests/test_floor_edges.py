"""Split columns (`mapper.floor_edges`, `MapperParams.edge_split_share`, `edge_split_lower_share`).

A frame splits a column when its floor points there belong to planes more than the gap apart;
the count goes to ``split_frames`` when the stored floor lies above the lowest plane (the
column holds the higher surface), else to ``lower_split_frames``. By hand on a few columns,
then through the mapper: a step whose front edge runs 2 cm inside a cell, seen exactly.
"""

import math

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.floor_edges import (
    SPLIT_FRAME_CAP,
    SPLIT_MIN_FRAMES,
    count_split_frames,
    mark_floor_edges,
)
from mapper.intrinsics import PinholeIntrinsics
from mapper.synthetic import Box, camera_rays_world, cast_frame

GAP_M = 0.015
N = np.nan


def count(floor, point_cell, heights, split=None, lower=None, multi=None):
    """One frame counted over ``len(floor)`` columns; returns the three counts and the result."""
    n = len(floor)
    split = np.zeros(n, np.int32) if split is None else np.array(split, np.int32)
    lower = np.zeros(n, np.int32) if lower is None else np.array(lower, np.int32)
    multi = np.zeros(n, np.int32) if multi is None else np.array(multi, np.int32)
    low, high, seen = np.full(n, np.inf), np.full(n, -np.inf), np.zeros(n, np.int32)
    result = count_split_frames(
        split,
        lower,
        multi,
        low,
        high,
        seen,
        np.array(floor, dtype=float),
        np.array(point_cell, dtype=np.int64),
        np.array(heights, dtype=float),
        GAP_M,
    )
    # The scratch is handed back as it came.
    assert np.all(low == np.inf) and np.all(high == -np.inf) and not seen.any()
    return split.tolist(), lower.tolist(), multi.tolist(), result


def test_a_frame_splits_the_columns_whose_planes_lie_more_than_the_gap_apart():
    # Column 0: a tread at 0 and one at 31 mm, the stored floor the higher: split.
    # Column 1: the same planes, the stored floor the lower: a lower split.
    # Column 2: two planes 5 mm apart (one surface's noise): multi only.
    # Column 3: one floor point (and a point that is not floor): nothing.
    # Column 4: no stored floor, two planes: a lower split (nothing stored above them).
    cells = [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, -1]
    heights = [0.0, 0.031, 0.031, 0.0, 0.0, 0.005, 0.2, N, 0.0, 0.031, 0.0]
    split, lower, multi, result = count([0.031, 0.0, 0.0, 0.2, N], cells, heights)
    assert split == [1, 0, 0, 0, 0]
    assert lower == [0, 1, 0, 0, 1]
    assert multi == [1, 1, 1, 0, 1]
    assert result == 3


def test_a_spread_of_exactly_the_gap_is_no_split():
    split, lower, multi, _ = count([0.015], [0, 0], [0.0, GAP_M])
    assert (split, lower, multi) == ([0], [0], [1])


def test_the_counts_are_halved_at_the_cap():
    # The 64th multi frame, split: 63 → 64 multi, 40 → 41 split, then all halved.
    split, lower, multi, _ = count(
        [0.031], [0, 0], [0.0, 0.031], split=[40], lower=[10], multi=[SPLIT_FRAME_CAP - 1]
    )
    assert (split, lower, multi) == ([20], [5], [SPLIT_FRAME_CAP // 2])


def mark(
    types,
    heights,
    window=None,
    *,
    floor=None,
    frame_votes=None,
    split=None,
    lower=None,
    multi=None,
    cover_ends=None,
    cover_passes=None,
    share=0.0,
    lower_share=0.0,
    contrast=0.0,
    min_frames=0,
    band=0.02,
    rims=False,
    min_rays=20,
    pass_fraction=0.2,
    eps=0.01,
    inward=0,
):
    """`mark_floor_edges` with every rule off but those given, counts 0 where not given."""
    shape = types.shape

    def counts(values):
        return np.zeros(shape, np.int32) if values is None else np.array(values, np.int32)

    return mark_floor_edges(
        types,
        heights,
        np.full(shape, np.nan) if floor is None else floor,
        counts(frame_votes),
        counts(split),
        counts(lower),
        counts(multi),
        counts(cover_ends),
        counts(cover_passes),
        share,
        lower_share,
        contrast,
        min_frames,
        band,
        rims,
        min_rays,
        pass_fraction,
        eps,
        inward,
        *((0, shape[0], 0, shape[1]) if window is None else window),
    )


def edges(split, multi=None, lower=None, share=1e-9, lower_share=0.0, contrast=0.0):
    """Which columns of an all-floor grid the split rule makes unknown (the whole grid)."""
    split = np.array(split, dtype=np.int32, ndmin=2)
    lower = np.zeros_like(split) if lower is None else np.array(lower, np.int32, ndmin=2)
    multi = np.zeros_like(split) if multi is None else np.array(multi, np.int32, ndmin=2)
    types = np.full(split.shape, np.int8(CellType.FLOOR))
    heights = np.zeros(split.shape)
    changed = mark(
        types,
        heights,
        split=split,
        lower=lower,
        multi=multi,
        share=share,
        lower_share=lower_share,
        contrast=contrast,
    )
    unknown = types == CellType.UNKNOWN
    assert changed == unknown.sum() and np.isnan(heights[unknown]).all()
    assert (heights[~unknown] == 0).all()
    return unknown


def test_the_share_needs_two_frames_of_its_kind():
    split, multi = [1, 2, 2, 3, 0], [1, 10, 6, 10, 0]
    assert SPLIT_MIN_FRAMES == 2
    assert edges(split, multi, share=0.3)[0].tolist() == [False, False, True, True, False]
    assert edges(split, multi, share=0.2)[0].tolist() == [False, True, True, True, False]
    # The lower kind by its own share; a share of 0 leaves its kind out.
    lower_only = edges([0] * 5, multi, lower=split, share=0.2, lower_share=0.3)
    assert lower_only[0].tolist() == [False, False, True, True, False]
    assert not edges(split, multi, share=0.0, lower_share=0.2).any()


def test_only_floors_are_judged():
    types = np.array([[CellType.OBSTACLE, CellType.UNKNOWN, CellType.FLOOR]], dtype=np.int8)
    heights = np.array([[0.3, np.nan, 0.1]])
    split = np.full((1, 3), 5, dtype=np.int32)
    assert mark(types, heights, split=split, share=0.2) == 1
    assert types.tolist() == [[CellType.OBSTACLE, CellType.UNKNOWN, CellType.UNKNOWN]]
    assert heights[0, 0] == 0.3
    # Only the window is judged.
    types[0, 2] = CellType.FLOOR
    assert mark(types, heights, (0, 1, 0, 2), split=split, share=0.2) == 0


def test_a_column_stands_out_across_an_edge_not_along_it():
    # A riser along y through column x = 1 (split 30 times), its neighbours across split 8 and
    # 10 times: it stands out 3 times across x (30 >= 3 * 10), whatever its neighbours along y.
    split = [[8, 8, 8], [30, 30, 30], [10, 10, 10]]
    assert edges(split, contrast=3.0)[1].tolist() == [True, True, True]
    # A riser on the boundary between rows 1 and 2 splits both about as often: neither does
    # (the middle column; at the array's sides a diagonal leaves it, and beyond counts as 0).
    split = [[2, 2, 2], [30, 30, 30], [25, 25, 25]]
    assert not edges(split, contrast=3.0)[1:, 1].any()
    # 11 across, 3 × 11 > 30: not with contrast 3, with 2.5.
    split = [[0, 0, 0], [30, 30, 30], [11, 11, 11]]
    assert not edges(split, contrast=3.0)[1, 1]
    assert edges(split, contrast=2.5)[1, 1]
    # Both kinds of split frames count, the column's and its neighbours'.
    assert not edges(split, lower=[[0, 0, 0], [0, 0, 0], [5, 5, 5]], contrast=2.5)[1, 1]


def test_a_diagonal_edge_stands_out_across_a_diagonal():
    # Split along the diagonal (0, 0)-(2, 2), its off-diagonal neighbours never: the centre
    # stands out across the other diagonal and across x and y.
    assert edges(np.eye(3, dtype=np.int32) * 20, contrast=3.0)[1, 1]
    # Beyond the grid counts as never split: a corner column with no neighbour split.
    assert edges([[5, 0], [0, 0]], contrast=3.0)[0, 0]


@pytest.mark.parametrize(
    "name", ["edge_split_share", "edge_split_lower_share", "edge_split_contrast"]
)
def test_shares_outside_0_1_are_refused(name):
    too_big = 1.5 if name != "edge_split_contrast" else math.inf
    with pytest.raises(InvalidParameterError, match=name):
        MapperParams(**{name: too_big})
    with pytest.raises(InvalidParameterError, match=name):
        MapperParams(**{name: -0.1})


def test_a_negative_gap_is_refused():
    with pytest.raises(InvalidParameterError, match="edge_split_gap_m"):
        MapperParams(edge_split_gap_m=-0.01)


# Through the mapper: a 31 mm step seen exactly from 0.9 m up, each frame shifted along x by a
# believed pose 5–15 mm off, as pose error moves an edge from frame to frame.
RAYS = camera_rays_world(PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0), 0.0, 30.0)
CAMERA = np.array([0.0, 0.0, 0.9])
SHIFTS_M = (-0.015, 0.005, -0.005, 0.015)


def labels(edge_x_m, recenter_x_m=1.0, shifts_m=SHIFTS_M, frames=8, **params):
    """FOG labels and heights [mm] at y = 0.02 m: the column at x = 1.02 m and two either side.

    The grid is centred on x = 1 m for ``frames`` frames, the believed pose off along x by
    ``shifts_m`` in turn, then on ``recenter_x_m`` for one more, unshifted (its FOG computed
    afresh there from the scrolled counts).
    """
    step = Box(center_xy=(edge_x_m + 0.5, 0.0), size_xyz=(1.0, 1.6, 0.031))
    fog = FloorObstacleMapper(MapperParams(**params), center_xy_m=(1.0, 0.0))
    points, heights = cast_frame(CAMERA, RAYS, (step,))
    for k in range(frames):
        shift = np.array([shifts_m[k % len(shifts_m)], 0.0, 0.0])
        fog.update(points + shift, heights, CAMERA + shift)
    fog.recenter(recenter_x_m, 0.0)
    fog.update(points, heights, CAMERA)
    types, fog_heights = fog.fog()
    ix, iy = fog.cell_of(np.array([[1.02, 0.02, 0.0]]))[0][0][:2]
    # The lattice: the cell of 1.02 m spans 1.00–1.04 m.
    assert abs(float(fog.cell_center(ix, iy)[0]) - 1.02) < 1e-9
    columns = range(ix - 2, ix + 3)
    return [int(types[i, iy]) for i in columns], [fog_heights[i, iy] * 1000 for i in columns]


F, OB, U = int(CellType.FLOOR), int(CellType.OBSTACLE), int(CellType.UNKNOWN)
OFF = {"edge_split_share": 0.0, "edge_split_lower_share": 0.0}
ON: dict[str, float] = {}  # the defaults


def test_the_column_a_step_edge_runs_through_is_unknown_with_the_rule():
    # The edge 1 cm inside the cell (3 cm of it the step): off, the cell is a floor at the
    # step's height, which the truth calls an obstacle; on, unknown. The rest as before.
    off_types, off_heights = labels(1.01, **OFF)
    on_types, on_heights = labels(1.01, **ON)
    assert off_types == [F, OB, F, F, F]
    assert off_heights[2] == pytest.approx(31.0, abs=0.1)
    assert on_types == [F, OB, U, F, F]
    assert np.isnan(on_heights[2])


def test_an_edge_on_a_cell_boundary_keeps_its_floors_here():
    # The edge at 1.00 m, the cell's side: the split frames of the pose's shifts stay below
    # the share, and every label is what it is without the rule.
    assert labels(1.00, **ON) == labels(1.00, **OFF)


def test_the_counts_scroll_with_the_grid():
    # Recentred 0.4 m (10 cells) on: the unknown cell stays at its place in the world.
    assert labels(1.01, recenter_x_m=1.4, **ON)[0] == [F, OB, U, F, F]


def test_the_contrast_keeps_the_columns_beside_a_riser_on_a_boundary():
    # The riser at 1.00 m, the believed pose 20 mm behind or ahead in turn: the edge falls in
    # the column before it or the one after it, each split in about half the frames. The share
    # alone makes the lower tread's last column (0.96–1.00 m) unknown; with the contrast (3)
    # neither column stands out and it stays a floor, as with the rule off.
    def last_lower_column(**params):
        types, _ = labels(1.00, shifts_m=(-0.02, 0.02), frames=12, **params)
        return types[1]  # 0.96–1.00 m

    assert last_lower_column(**OFF) == F
    assert last_lower_column(edge_split_contrast=0.0) == U
    assert last_lower_column() == F


# A raised floor's weak foot (`MapperParams.edge_foot_min_frames`).
BAND_M = 0.02


def feet(floor_mm, votes, fog_types=None, min_frames=8, window=None):
    """The FOG labels after the rule, on a grid whose floors are all labelled floor."""
    floor = np.array(floor_mm, float) / 1000
    types = (
        np.where(np.isnan(floor), U, F).astype(np.int8)
        if fog_types is None
        else np.array(fog_types, np.int8)
    )
    heights = np.where(types == F, floor, np.nan)
    changed = mark(
        types,
        heights,
        window,
        floor=floor,
        frame_votes=votes,
        min_frames=min_frames,
        band=BAND_M,
    )
    assert changed == int(np.sum(np.isnan(heights) & (types == U) & ~np.isnan(floor)))
    return types.tolist()


def test_a_floor_few_frames_confirmed_beside_a_raised_floor_is_unknown():
    # Column 1 (ground, 3 votes) beside column 2 (platform 122 mm, 40): unknown. Column 0 has
    # 3 votes too, but no raised neighbour; column 2 is the higher one.
    assert feet([[0.0, 0.0, 122.0]], [[3, 3, 40]]) == [[F, U, F]]


def test_a_floor_confirmed_by_the_minimum_stays():
    assert feet([[0.0, 0.0, 122.0]], [[3, 8, 40]]) == [[F, F, F]]
    assert feet([[0.0, 0.0, 122.0]], [[3, 8, 40]], min_frames=9) == [[F, U, F]]


def test_the_rise_must_exceed_the_band():
    # 20 mm above: no raised floor (the band); 21 mm: one. A NaN neighbour never is.
    assert feet([[0.0, 20.0]], [[1, 40]]) == [[F, F]]
    assert feet([[0.0, 21.0]], [[1, 40]]) == [[U, F]]
    assert feet([[0.0, N]], [[1, 0]]) == [[F, U]]


def test_a_diagonal_raised_neighbour_counts():
    assert feet([[0.0, 0.0], [0.0, 122.0]], [[2, 40], [40, 40]]) == [[U, F], [F, F]]


def test_weak_feet_are_floors_in_the_window():
    # An obstacle with few votes stays one; the window [1, 2) x [0, 1) leaves column 0 alone.
    assert feet([[0.0, 122.0]], [[1, 40]], fog_types=[[OB, F]]) == [[OB, F]]
    assert feet([[0.0, 0.0, 122.0]], [[1, 1, 40]], window=(0, 1, 0, 3)) == [[F, U, F]]
    assert feet([[0.0], [0.0], [122.0]], [[1], [1], [40]], window=(1, 2, 0, 1)) == [
        [F],
        [U],
        [F],
    ]


def test_a_minimum_above_the_frame_cap_is_refused():
    with pytest.raises(InvalidParameterError, match=r"edge_foot_min_frames.*floor_frame_cap"):
        MapperParams(edge_foot_min_frames=41, floor_frame_cap=40)
    with pytest.raises(InvalidParameterError, match="edge_foot_min_frames"):
        MapperParams(edge_foot_min_frames=-1)


def side_ground_labels(full_frames, **params):
    """FOG labels of the ground column before a 122 mm box and of the box's second column.

    The box spans x = 1.00 … 2.00 m. ``full_frames`` frames see everything, then 12 see only
    the box's top and the ground away from it (the ground beside the box hidden, as behind a
    side edge): the ground column 0.96–1.00 m is confirmed by ``full_frames`` frames.
    """
    box = Box(center_xy=(1.5, 0.0), size_xyz=(1.0, 1.6, 0.122))
    fog = FloorObstacleMapper(MapperParams(**params), center_xy_m=(1.0, 0.0))
    points, heights = cast_frame(CAMERA, RAYS, (box,))
    beside = (points[:, 0] > 0.9) & (points[:, 0] < 1.0)
    for k in range(full_frames + 12):
        keep = slice(None) if k < full_frames else ~beside
        fog.update(points[keep], heights[keep], CAMERA)
    types, _ = fog.fog()
    ground, top = fog.cell_of(np.array([[0.98, 0.02, 0.0], [1.06, 0.02, 0.0]]))[0]
    return int(types[ground[0], ground[1]]), int(types[top[0], top[1]])


def test_through_the_mapper_a_ground_column_seen_twice_before_a_box_is_unknown():
    # Seen by 2 frames: unknown with the rule, a floor without it; seen by 10: a floor.
    assert side_ground_labels(2, edge_foot_min_frames=0) == (F, F)
    assert side_ground_labels(2) == (U, F)
    assert side_ground_labels(10) == (F, F)


# A raised floor's rim beside its uncovered spill (`MapperParams.uncovered_rims`). One row
# along y: ground, then the platform from column 1, whose last stored column (7) is spill the
# rays pass through, then ground again.
PLATFORM_ROW_MM = [0.0, 122.0, 122.0, 122.0, 122.0, 122.0, 122.0, 122.0, 0.0]
SPILL = 7  # the platform's last column: 30 rays ended on it, 40 passed through it
RIM = 6


def rims(
    floor_mm=PLATFORM_ROW_MM,
    ends=30,
    passes=40,
    split=0,
    inward=4,
    min_rays=20,
    fog_types=None,
    window=None,
):
    """The row's FOG labels after the rule (floors everywhere a floor is stored)."""
    floor = np.array([floor_mm], float) / 1000
    n = floor.shape[1]
    cover_ends = np.full((1, n), 100, np.int32)
    cover_passes = np.zeros((1, n), np.int32)
    cover_ends[0, SPILL], cover_passes[0, SPILL] = ends, passes
    splits = np.zeros((1, n), np.int32)
    splits[0, SPILL] = split
    types = (
        np.where(np.isnan(floor), U, F).astype(np.int8)
        if fog_types is None
        else np.array([fog_types], np.int8)
    )
    heights = np.where(types == F, floor, np.nan)
    mark(
        types,
        heights,
        window,
        floor=floor,
        split=splits,
        cover_ends=cover_ends,
        cover_passes=cover_passes,
        rims=True,
        min_rays=min_rays,
        inward=inward,
    )
    return types[0].tolist()


def test_the_floor_beside_its_surface_s_uncovered_last_column_is_unknown():
    # 40 of the 70 rays reaching the spill passed through it: the platform's edge lies about
    # there, and the rim beside it (column 6) is unknown; the spill itself is the cover check's.
    expected = [F] * 9
    expected[RIM] = U
    assert rims() == expected


def test_a_covered_last_column_leaves_the_rim():
    # 14 of 70 passed (0.2): covered. 19 rays in all: not judged.
    assert rims(ends=56, passes=14) == [F] * 9
    assert rims(ends=4, passes=15) == [F] * 9
    assert rims(ends=4, passes=15, min_rays=19)[RIM] == U


def test_a_split_last_column_is_the_split_rule_s():
    # Two frames saw both surfaces in the spill's column: a riser seen from the front.
    assert rims(split=2) == [F] * 9
    assert rims(split=1)[RIM] == U


def test_only_the_surface_s_last_column_counts():
    # The platform goes on beyond the uncovered column: a hole in the surface, no edge.
    row = list(PLATFORM_ROW_MM)
    row[8] = 122.0
    assert rims(floor_mm=row) == [F] * 9
    # Another surface's column (more than eps from the rim's height) never counts.
    row = list(PLATFORM_ROW_MM)
    row[SPILL] = 100.0
    assert rims(floor_mm=row) == [F] * 9
    # Beyond the grid the surface has ended.
    assert rims(floor_mm=PLATFORM_ROW_MM[:8])[RIM] == U


def test_a_narrow_rise_keeps_its_rims():
    # The platform must go on for `inward` cells behind the rim (columns 2-5 with 4): with a
    # stored ground at column 3 it does not (a sill, a low box: the narrow-rise rule's).
    row = list(PLATFORM_ROW_MM)
    row[3] = 0.0
    assert rims(floor_mm=row) == [F] * 9
    assert rims(floor_mm=row, inward=2)[RIM] == U
    assert rims(inward=5)[RIM] == U
    assert rims(inward=6) == [F] * 9


def test_uncovered_rims_are_floors_in_the_window():
    labels = [F] * 9
    labels[RIM] = OB
    assert rims(fog_types=labels) == labels
    assert rims(window=(0, 1, 0, RIM)) == [F] * 9
    assert rims(window=(0, 1, RIM, RIM + 1))[RIM] == U


def side_labels(edge_y_m, **params):
    """FOG labels at x = 1.42 m of the cells y = -0.18 ... 0.10 m across a platform's side.

    The 122 mm platform spans x = 1 ... 2 m and y up to ``edge_y_m``; the camera 0.9 m up at
    y = 0.3 m, looking along x, sees its top and the ground beside it, 12 frames, exactly.
    """
    box = Box(center_xy=(1.5, edge_y_m - 0.5), size_xyz=(1.0, 1.0, 0.122))
    fog = FloorObstacleMapper(MapperParams(**params), center_xy_m=(1.0, 0.0))
    camera = CAMERA + np.array([0.0, 0.3, 0.0])
    points, heights = cast_frame(camera, RAYS, (box,))
    for _ in range(12):
        fog.update(points, heights, camera)
    types, _ = fog.fog()
    ys = np.arange(-0.18, 0.12, 0.04)
    cells = [fog.cell_of(np.array([[1.42, y, 0.0]]))[0][0][:2] for y in ys]
    return [int(types[ix, iy]) for ix, iy in cells]


def test_through_the_mapper_a_side_edge_on_a_cell_boundary_keeps_its_rim():
    # Edge at y = 0: the platform's cells are floors up to y = 0, the side face's cell an
    # obstacle; nothing passes through a floor, so the rule changes nothing.
    assert side_labels(0.0) == side_labels(0.0, uncovered_rims=False)
    assert side_labels(0.0) == [F, F, F, F, F, OB, F, F]


def test_through_the_mapper_the_rim_beside_a_spill_is_given_up():
    # Edge at y = 0.03: the cell 0.00-0.04 m holds 3 cm of platform, whose floor the rays to
    # the ground beyond pass through (the cover check's unknown). The cell before it, all
    # platform, is what the rule gives up: with drift the edge may lie in it (module note).
    assert side_labels(0.03, uncovered_rims=False) == [F, F, F, F, F, U, F, F]
    assert side_labels(0.03) == [F, F, F, F, U, U, F, F]
