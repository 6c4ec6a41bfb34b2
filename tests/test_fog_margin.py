"""The FOG's neighbourhood rules beyond the paper, on hand-built grids (`mapper.fog`).

Obstacle margin (`MapperParams.obstacle_margin_cells`): with a margin of m cells a cell whose
floor ``h_f`` eq. 11 keeps is an obstacle when the highest obstacle top (eq. 10,
``z_min + (k + 1)·layer`` of the highest occupied layer k) within m cells exceeds ``h_f + δ``;
its height is then that top. Edge band (`MapperParams.edge_band_m`): a cell eq. 11 and the
cover check label floor at ``h_f`` is unknown when one of its 8 neighbours is labelled floor
more than the band below ``h_f`` (the rim of a raised surface), or (unknown beside obstacles)
obstacle with a height more than δ above ``h_f`` that is no higher floor's edge (no stored
floor within a cell of it lies within δ below its top).
With the default grid (z_min −0.06 m, layers of 0.04 m, δ 0.05 m) a surface at h lies in layer
``floor((h + 0.06) / 0.04)``, so its cells' top is: ground 0 → 0.02, sill 0.038 → 0.06,
31 mm → 0.06, 61 mm → 0.10, 92 mm → 0.10, 122 mm → 0.14.
"""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.fog import update_fog_area

P = MapperParams()
Z0, L = P.z_min_m, P.layer_m
OCC = 230
F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN


def layer_of(h):
    return int(np.floor((h - Z0) / L))


def surfaces_grid(heights_m, ny=3, tops_m=None):
    """A (n, ny) grid, every row alike: column ix holds a floor at ``heights_m[ix]`` (NaN: none)
    and, where ``tops_m[ix]`` is given, occupied layers from the ground's up to the one holding
    that top (an obstacle)."""
    n = len(heights_m)
    tops_m = tops_m or [np.nan] * n
    og = np.full((n, ny, P.nz), 128, dtype=np.uint8)
    floor = np.full((n, ny), np.nan)
    for ix, (h, top) in enumerate(zip(heights_m, tops_m, strict=True)):
        if np.isfinite(h):
            og[ix, :, layer_of(h)] = OCC
            floor[ix, :] = h
        if np.isfinite(top):
            og[ix, :, layer_of(0.0) : layer_of(top) + 1] = OCC
    return og, floor


def fog(
    og, floor, margin=0, area=None, types=None, band=0.0, beside=False, ends=None, passes=None,
    rise=0, shadow=0, island=0, spill=False, seen_drop=False, ground_noise=False,
):  # fmt: skip
    """Types and heights after `update_fog_area` over ``area`` (default: the whole grid);
    ``types`` pre-fills the FOG (default −1: no label, to see which cells were written). The
    cover check has its default parameters and, unless given, no rays counted (off)."""
    nx, ny = floor.shape
    ix0, ix1, iy0, iy1 = area or (0, nx, 0, ny)
    types = np.full((nx, ny), -1, dtype=np.int8) if types is None else types
    heights = np.full((nx, ny), -1.0)
    obstacle = np.full((nx, ny), np.nan)
    zeros = np.zeros((nx, ny), dtype=np.int32)
    ends = zeros if ends is None else ends
    passes = zeros if passes is None else passes
    update_fog_area(
        og, floor, obstacle, types, heights, P.occ_threshold_level, Z0, L, P.delta_m,
        ix0, ix1, iy0, iy1, ends, passes, P.floor_pass_min_rays, P.floor_pass_fraction,
        margin, band, beside, rise, shadow, island, spill, seen_drop, ground_noise,
    )  # fmt: skip
    return types, heights


def test_sill_edge_inside_a_cell_is_obstacle():
    # x: ground, ground, the sill's near edge cell (3/4 ground: its points and floor are the
    # ground's, its sliver of sill top left no occupied cell), sill, sill, the far edge cell
    # (ground behind the sill), ground. The sill cells' top is 0.06 > 0 + δ = 0.05.
    og, floor = surfaces_grid([0.0, 0.0, 0.0, 0.038, 0.038, 0.0, 0.0])
    types, heights = fog(og, floor, margin=1)
    assert types[:, 1].tolist() == [F, F, OB, F, F, OB, F]
    assert heights[2, 1] == pytest.approx(0.06) and heights[5, 1] == pytest.approx(0.06)
    assert heights[3, 1] == 0.038  # the sill's own cells: 0.06 <= 0.038 + δ, floor
    # The paper (margin 0): every cell a floor at its own height.
    types0, heights0 = fog(og, floor, margin=0)
    assert types0[:, 1].tolist() == [F] * 7
    assert np.array_equal(heights0, floor)


def test_staircase_riser_feet_by_the_layer_rule():
    # ground | 31 | 61 | 92 | 122 mm, one cell each, tops 0.02, 0.06, 0.10, 0.10, 0.14:
    # ground beside 31: 0.06 > 0.05 obstacle; 31 beside 61: 0.10 > 0.081 obstacle;
    # 61 beside 92: 0.10 <= 0.111 floor; 92 beside 122: 0.14 <= 0.142 floor; 122 floor.
    og, floor = surfaces_grid([0.0, 0.031, 0.061, 0.092, 0.122])
    types, heights = fog(og, floor, margin=1)
    assert types[:, 1].tolist() == [OB, OB, F, F, F]
    assert heights[:, 1] == pytest.approx([0.06, 0.10, 0.061, 0.092, 0.122])


def test_plain_floor_beside_a_lower_surface_or_a_low_rise_stays_floor():
    # A floor is compared only with what stands above it: the platform's edge cell (0.122)
    # beside the ground, and ground beside ground 9 mm higher (the same layer, top 0.02).
    og, floor = surfaces_grid([0.122, 0.0, 0.009])
    types, _ = fog(og, floor, margin=1)
    assert types[:, 1].tolist() == [F, OB, F]  # the ground at the platform's foot only


def test_diagonal_neighbour_and_margin_two():
    # A box (layers 2–5 occupied, top −0.06 + 6 × 0.04 = 0.18) in the corner cell (0, 0)
    # of ground 5 × 5.
    og, floor = surfaces_grid([0.0] * 5, ny=5)
    og[0, 0, 2:6] = OCC
    types, heights = fog(og, floor, margin=1)
    expected = np.full((5, 5), F)
    expected[:2, :2] = OB  # the box (eq. 11) and its three neighbours, (1, 1) diagonal
    assert np.array_equal(types, expected)
    assert heights[1, 1] == pytest.approx(0.18)
    types2, _ = fog(og, floor, margin=2)
    expected[:3, :3] = OB
    assert np.array_equal(types2, expected)


def test_an_obstacle_keeps_its_own_top_and_no_floor_stays_unknown():
    # Cell 0: a box, layers 2–8 (top 0.30); cell 1: a ground floor with something in layer 3
    # (its own top 0.10 > δ: eq. 11's obstacle); cell 2: nothing seen. Cell 1 keeps its own
    # top, not the box's; cell 2 has no floor to compare.
    og, floor = surfaces_grid([0.0, 0.0, np.nan])
    og[0, :, 2:9] = OCC
    og[1, :, 3] = OCC
    types, heights = fog(og, floor, margin=1)
    assert types[:, 1].tolist() == [OB, OB, U]
    assert heights[:2, 1] == pytest.approx([0.30, 0.10])
    assert np.isnan(heights[2, 1])


def test_cells_within_the_margin_of_the_area_are_relabelled():
    # Only cell 2 changed (its column now holds a box): cells 1 and 3 lie outside the area but
    # their window reaches it; cells 0 and 4 are not touched (their sentinel -1 stays).
    og, floor = surfaces_grid([0.0] * 5, ny=1)
    og[2, 0, 2:6] = OCC
    types, _ = fog(og, floor, margin=1, area=(2, 3, 0, 1))
    assert types[:, 0].tolist() == [-1, OB, OB, OB, -1]


@pytest.mark.parametrize("margin", [-1, 100, 1.5, True])
def test_margin_validated(margin):
    with pytest.raises(InvalidParameterError, match="obstacle_margin_cells"):
        MapperParams(obstacle_margin_cells=margin)


def test_margin_override_takes_integral_floats():
    margin = P.with_overrides(obstacle_margin_cells=1.0).obstacle_margin_cells
    assert margin == 1 and type(margin) is int
    assert P.obstacle_margin_cells == 0  # the paper's eq. 11


def test_the_mapper_takes_the_margin_from_its_params():
    """End to end: `FloorObstacleMapper` passes `obstacle_margin_cells` to eq. 11.

    A floor patch at 0 over x 0.6..1.0 (cells 65..74), an obstacle 0.055 m high filling cell
    (70, 50) (x 0.80..0.84, y 0..0.04). Margin 0: its neighbours are floor (the paper's rule);
    margin 1: the 8 cells around it are obstacles at its top, cells two away stay floor. The
    unknown beside obstacles is off (it would make the floor beside the obstacle unknown).
    """
    sensor = np.array([0.0, 0.0, 0.55])
    labels = {}
    for margin in (0, 1):
        rng = np.random.default_rng(2)
        m = FloorObstacleMapper(
            MapperParams(obstacle_margin_cells=margin, unknown_beside_obstacles=False)
        )
        for _ in range(10):
            n = 600
            floor_pts = np.column_stack(
                [rng.uniform(0.6, 1.0, n), rng.uniform(-0.2, 0.2, n), rng.uniform(-0.005, 0.005, n)]
            )
            zz = np.linspace(0.0, 0.055, 12)
            face = np.column_stack([np.full(12, 0.8001), np.full(12, 0.02), zz])
            lid = np.column_stack(
                [rng.uniform(0.8, 0.84, 12), rng.uniform(0, 0.04, 12), np.full(12, 0.055)]
            )
            points = np.vstack([floor_pts, face, lid])
            heights = np.concatenate([np.zeros(n), np.full(24, np.nan)])
            m.update(points, heights, sensor)
        labels[margin] = m.fog()
    (types0, _), (types1, heights1) = labels[0], labels[1]
    ring = (slice(69, 72), slice(49, 52))
    assert types0[70, 50] == CellType.OBSTACLE and types1[70, 50] == CellType.OBSTACLE
    assert np.sum(types0[ring] == CellType.FLOOR) == 8
    assert np.all(types1[ring] == CellType.OBSTACLE)
    assert np.allclose(heights1[ring], heights1[70, 50])
    assert types1[68, 50] == CellType.FLOOR and types1[70, 48] == CellType.FLOOR


# ------------------------------------------------------------------ edge band
BAND = 0.02


def test_sill_whose_near_edge_cell_took_the_sill_height():
    # x: ground, ground, the sill's near edge cell (a quarter sill: its sill points won the
    # votes), sill, sill, the far edge cell (3/4 ground: ground won), ground, ground. The truth
    # makes both edge cells obstacles; the paper's FOG makes every cell a floor at its height,
    # the near edge cell 37 mm off the ground under most of it.
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, heights = fog(og, floor, band=BAND, beside=True)
    # Jumps of 37 mm between cells 1|2 and 4|5: the sill's rim cells above them are unknown,
    # the ground cells below them floor.
    assert types[:, 1].tolist() == [F, F, U, F, U, F, F, F]
    assert np.isnan(heights[[2, 4], 1]).all() and heights[[1, 5], 1].tolist() == [0.0, 0.0]
    assert heights[3, 1] == 0.037 and heights[0, 1] == 0.0
    types0, heights0 = fog(og, floor, beside=True)  # no floor band
    assert types0[:, 1].tolist() == [F] * 8 and np.array_equal(heights0, floor)


def test_jumps_within_the_band_stay_floor():
    # Steps of 20 mm (not more than the band: floor), 21 mm (the higher side unknown), and
    # the diagonal neighbour counts as much as the others.
    og, floor = surfaces_grid([0.0, 0.02, 0.02, 0.041, 0.041])
    types, _ = fog(og, floor, band=BAND, beside=True)
    assert types[:, 1].tolist() == [F, F, F, U, F]
    og, floor = surfaces_grid([0.0, 0.0, 0.0], ny=3)
    floor[2, 2] = 0.03  # one cell, its diagonal neighbour (1, 1)
    types, _ = fog(og, floor, band=BAND, beside=True)
    assert types[2, 2] == U and types[1, 1] == F and types[0, 0] == F  # (1, 1): lower
    assert types[0, 2] == F  # two cells from (2, 2)


def test_floor_beside_an_obstacle_more_than_delta_above_it():
    # A rough box (no floor, occupied from the ground to layer 7: top 0.26) between ground
    # cells: its neighbours are unknown, it stays an obstacle at its top, cells two away floor.
    nan = np.nan
    og, floor = surfaces_grid([0.0, 0.0, nan, 0.0, 0.0], tops_m=[nan, nan, 0.25, nan, nan])
    types, heights = fog(og, floor, band=BAND, beside=True)
    assert types[:, 1].tolist() == [F, U, OB, U, F]
    only_obstacles, _ = fog(og, floor, beside=True)  # no floor band
    assert np.array_equal(only_obstacles, types)
    assert fog(og, floor)[0][:, 1].tolist() == [F, F, OB, F, F]  # the paper
    assert heights[2, 1] == pytest.approx(Z0 + (layer_of(0.25) + 1) * L) == pytest.approx(0.26)


def test_a_higher_floors_edge_is_no_obstacle_for_its_neighbours():
    # Ground | a riser cell seen as an obstacle (top 0.14) | the 122 mm platform: 0.14 is more
    # than δ above the ground but not above 0.122 + 0.05, so the platform stays floor, and the
    # obstacle is the platform's edge (its top is the platform's layer): the ground beside it
    # stays floor too, as a tread does at the foot of the next riser.
    nan = np.nan
    og, floor = surfaces_grid([0.0, 0.0, nan, 0.122, 0.122], tops_m=[nan, nan, 0.12, nan, nan])
    types, _ = fog(og, floor, band=BAND, beside=True)
    assert types[:, 1].tolist() == [F, F, OB, F, F]


def test_riser_foot_beside_the_next_tread_stays_floor_a_box_side_does_not():
    # step_1 (31 mm) | the riser cell, its floor step_1's and its top step_2's layer (0.10 >
    # 0.031 + δ: an obstacle) | step_2 (61 mm): the riser's top is step_2's, step_1 stays floor.
    nan = np.nan
    og, floor = surfaces_grid([0.031, 0.031, 0.031, 0.061, 0.061], tops_m=[nan] * 5)
    og[2, :, layer_of(0.061)] = OCC  # step_2's edge inside the riser cell
    types, _ = fog(og, floor, beside=True)
    assert types[:, 1].tolist() == [F, F, OB, F, F]
    # A box as high (top 0.10) with no floor near its top: the cells beside it are unknown.
    og, floor = surfaces_grid([0.031, 0.031, 0.031, nan, nan], tops_m=[nan, nan, nan, 0.09, 0.09])
    types, _ = fog(og, floor, beside=True)
    assert types[:, 1].tolist() == [F, F, U, OB, OB]


def test_neighbour_the_cover_check_makes_unknown_bands_nothing():
    # Cell 2 holds a 37 mm floor passed by 10 of 30 rays (> 0.2): unknown, so it is no edge
    # for its neighbours, which stay floor.
    og, floor = surfaces_grid([0.0, 0.0, 0.037, 0.0, 0.0])
    ends = np.zeros(floor.shape, dtype=np.int32)
    passes = np.zeros(floor.shape, dtype=np.int32)
    ends[2, :], passes[2, :] = 20, 10
    types, _ = fog(og, floor, band=BAND, beside=True, ends=ends, passes=passes)
    assert types[:, 1].tolist() == [F, F, U, F, F]


def test_ring_around_the_area_is_relabelled_as_a_whole_grid_update_would():
    # A 61 mm strip three cells wide (cells 3-5); only cell 4 changed (area [4, 5) x all rows).
    # With the bands its ring two cells wide is relabelled too (whether a neighbour is a higher
    # floor's edge or a shadow depends on the maps beside it): cells 3 and 5 above the ground
    # beside them unknown, cell 4 between two floors of its own height and the ground cells
    # 2 and 6 floor; cells three away are left as they were (-1). The whole-grid update gives
    # the same labels: the neighbours' labels come from the maps, not from the FOG being written.
    og, floor = surfaces_grid([0.0, 0.0, 0.0, 0.061, 0.061, 0.061, 0.0, 0.0, 0.0])
    for beside in (False, True):
        types, heights = fog(og, floor, band=BAND, beside=beside, area=(4, 5, 0, 3))
        assert types[:, 1].tolist() == [-1, -1, F, U, F, U, F, -1, -1]
        assert heights[4, 1] == 0.061
        full, _ = fog(og, floor, band=BAND, beside=beside)
        assert np.array_equal(full[2:7], types[2:7])
        assert full[:, 1].tolist() == [F, F, F, U, F, U, F, F, F]
    paper, _ = fog(og, floor, area=(4, 5, 0, 3))
    assert paper[:, 1].tolist() == [-1, -1, -1, -1, F, -1, -1, -1, -1]


def test_the_cell_before_a_shadow_behind_a_rim_is_unknown():
    # Platform (122 mm) | its last cell, the platform's height spilled over its side edge |
    # the ground hidden behind the edge: nothing stored | the ground seen beyond. The spilled
    # cell is unknown; with a floor or an obstacle stored in the gap it is not (the band
    # looks at direct neighbours only); without a lower floor beyond, neither.
    nan = np.nan
    og, floor = surfaces_grid([0.122, 0.122, 0.122, nan, 0.0, 0.0])
    types, _ = fog(og, floor, band=BAND)
    assert types[:, 1].tolist() == [F, F, U, U, F, F]
    og2, floor2 = surfaces_grid([0.122, 0.122, 0.122, 0.122, 0.0, 0.0])
    assert fog(og2, floor2, band=BAND)[0][:, 1].tolist() == [F, F, F, U, F, F]
    og3, floor3 = surfaces_grid([0.122, 0.122, 0.122, nan, nan, nan])
    assert fog(og3, floor3, band=BAND)[0][:, 1].tolist() == [F, F, F, U, U, U]
    assert fog(og, floor)[0][:, 1].tolist() == [F, F, F, U, F, F]  # the paper


def test_a_floor_change_beside_an_obstacle_relabels_two_cells_away():
    # Ground | ground | an edge cell (floor 0, top 0.10: an obstacle) | cell 3, whose floor
    # changes from none (the edge a box's: cell 1 unknown) to 61 mm (a step's: cell 1 floor).
    # Only cell 3 is in the area; cell 1, two away, is relabelled as the whole grid would be.
    nan = np.nan
    og, floor = surfaces_grid([0.0, 0.0, 0.0, nan, nan])
    og[2, :, layer_of(0.061)] = OCC
    og[3, :, layer_of(0.061)] = OCC
    nx, ny = floor.shape
    types = np.full((nx, ny), -1, dtype=np.int8)
    heights = np.full((nx, ny), np.nan)
    obstacle = np.full((nx, ny), np.nan)  # kept: the kernel takes it as current outside the area
    zeros = np.zeros((nx, ny), dtype=np.int32)

    def update(area):
        update_fog_area(
            og, floor, obstacle, types, heights, P.occ_threshold_level, Z0, L, P.delta_m,
            *area, zeros, zeros, P.floor_pass_min_rays, P.floor_pass_fraction, 0, 0.0, True,
        )  # fmt: skip

    update((0, nx, 0, ny))
    assert types[:, 1].tolist() == [F, U, OB, OB, U]
    floor[3, :] = 0.061
    update((3, 4, 0, ny))
    assert types[:, 1].tolist() == [F, F, OB, F, U]
    assert np.array_equal(types, fog(og, floor, beside=True)[0])


@pytest.mark.parametrize("band", [-0.01, float("nan"), float("inf")])
def test_band_validated(band):
    with pytest.raises(InvalidParameterError, match="edge_band_m"):
        MapperParams(edge_band_m=band)


def test_band_defaults():
    assert P.edge_band_m == 0.02 and P.unknown_beside_obstacles is True
    paper = MapperParams(edge_band_m=0.0, unknown_beside_obstacles=False)
    assert paper.edge_band_m == 0.0 and not paper.unknown_beside_obstacles


# ------------------------------------------------------------------ narrow rises
RISE = P.narrow_rise_cells  # 4 cells (0.16 m)


def test_both_feet_of_a_sill_are_unknown():
    # The sill of `test_sill_whose_near_edge_cell_took_the_sill_height`, 3 cells deep: the band
    # leaves its rims (cells 2 and 4) unknown; with narrow rises the ground cells at its feet
    # are unknown too (cell 1: its neighbour 2 is 37 mm higher and the floors drop again at
    # cell 5, 3 cells beyond that neighbour, within 4; cell 5 the same from the other side),
    # the ground cells farther away (0, 6, 7) floor, the sill's middle (3) floor at its height.
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, heights = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[:, 1].tolist() == [F, U, U, F, U, U, F, F]
    assert heights[3, 1] == 0.037 and heights[0, 1] == 0.0 and heights[6, 1] == 0.0
    # Without the band the rule is off (it completes the rim rule).
    types0, _ = fog(og, floor, beside=True, rise=RISE)
    assert types0[:, 1].tolist() == [F] * 8


def test_a_rise_deeper_than_the_limit_or_a_tread_keeps_the_cells_at_its_foot():
    # A raised surface 5 cells deep (one more than the 4 scanned beyond the neighbour): from
    # cell 1 the floors of cells 3..6 are the surface's, no drop within reach, so the ground
    # cells at its feet stay floor; its rims are unknown.
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.037, 0.037, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[:, 1].tolist() == [F, F, U, F, F, F, U, F, F]
    # 4 cells deep: the drop at cell 6 lies 4 cells beyond cell 1's neighbour (cell 2).
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.037, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[:, 1].tolist() == [F, U, U, F, F, U, U, F]
    # A staircase, treads 2 cells deep: every tread leads to a higher one (no drop beyond the
    # next riser), so the cell at each riser's foot stays floor; each rim is unknown.
    floors = [0.0, 0.0, 0.031, 0.031, 0.061, 0.061, 0.092, 0.092]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[:, 1].tolist() == [F, F, U, F, U, F, U, F]


def test_cells_without_a_floor_are_skipped_and_the_rule_runs_along_y_too():
    # The drop behind the sill is seen past two cells with no stored floor (a shadow); and the
    # same sill turned 90° (along y) gives the same labels.
    nan = np.nan
    floors = [0.0, 0.0, 0.037, nan, 0.037, nan, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[1, 1] == U and types[0, 1] == F
    floors = [0.0, 0.0, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors, ny=3)
    along_x, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    along_y, _ = fog(
        np.ascontiguousarray(og.transpose(1, 0, 2)),
        np.ascontiguousarray(floor.T),
        band=BAND,
        beside=True,
        rise=RISE,
    )
    assert along_x[:, 1].tolist() == [F, U, U, U, U, F, F]
    assert np.array_equal(along_y.T, along_x)
    # One cell deep (a tread's points spilled a cell over its riser): no narrow rise, the
    # band leaves the cell itself unknown, its neighbours floor.
    og, floor = surfaces_grid([0.0, 0.0, 0.037, 0.0, 0.0])
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[:, 1].tolist() == [F, F, U, F, F]


def test_a_floor_change_relabels_the_foot_of_a_rise_beyond_the_band_ring():
    # Updating only the cell where the ground behind a sill appears (cell 6, where the sill
    # seemed to go on: 5 cells deep, too deep for the rule) relabels the ground cell at the
    # sill's near foot (cell 1), 5 cells away, as a whole-grid update does.
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.037, 0.037, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[1, 1] == F
    floor[6, :] = 0.0
    og[6, :, :] = 128
    og[6, :, layer_of(0.0)] = OCC
    part, _ = fog(
        og, floor, area=(6, 7, 0, 3), types=types.copy(), band=BAND, beside=True, rise=RISE
    )
    whole, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert part[1, 1] == U and np.array_equal(part, whole)


def test_a_rise_ending_in_cells_never_seen_is_narrow():
    # The stage's sill seen from beyond (depth seed 5): 3 cells deep, the ground before it never
    # seen (the robot's standing place, hidden by its feet: nothing stored, no floor, no
    # obstacle), the ground beyond it a floor. The old scan went on through the unseen cells,
    # found no drop within 4 and left the far foot (cell 8) a floor at the ground's height — on
    # the far edge cell, which may hold the riser. An unseen cell ends the surface as far as
    # known: the far foot is unknown; the ground farther (9, 10) stays floor.
    nan = np.nan
    floors = [0.0, nan, nan, nan, nan, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[8, 1] == U and types[9:, 1].tolist() == [F, F]
    assert types[0, 1] == F and types[6, 1] == F  # the ground before, the sill's middle
    # A cell with an obstacle but no floor (a riser's cell, a box's side) is no end: a surface
    # 5 cells deep with such a cell in it keeps the cells at its feet.
    floors = [0.0, 0.0, 0.037, 0.037, nan, 0.037, 0.037, 0.037, 0.0]
    tops = [nan, nan, nan, nan, 0.05, nan, nan, nan, nan]
    og, floor = surfaces_grid(floors, tops_m=tops)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[1, 1] == F and types[8, 1] == F
    # A single raised cell before the unseen one (a spill) is no surface: the foot stays floor.
    floors = [0.0, 0.0, 0.037, nan, nan, nan, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[1, 1] == F


def test_the_near_rim_of_a_narrow_rise_before_an_unseen_foot_is_unknown():
    # The stage's sill (depth seed 7), 4 cells deep: the ground before it hidden behind a box
    # (cells 1-2: nothing stored), the ground beyond it a floor. The rim rule finds no lower
    # floor beside the near edge cell (3), which kept the sill's height — on a cell the edge
    # may cross. Its foot unseen and the surface dropping within 4 cells, it is unknown; the
    # far rim (6) by the rim rule, the far foot (7) by the narrow rise, the middle (4, 5) floor.
    nan = np.nan
    floors = [0.0, nan, nan, 0.037, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, heights = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[3:, 1].tolist() == [U, F, F, U, U, F, F]
    assert heights[4, 1] == 0.037
    # Along y the same.
    along_y, _ = fog(
        np.ascontiguousarray(og.transpose(1, 0, 2)),
        np.ascontiguousarray(floor.T),
        band=BAND,
        beside=True,
        rise=RISE,
    )
    assert np.array_equal(along_y.T, types)
    # A surface 5 cells deep (a platform, a tread leading on) keeps its rim before the unseen
    # cells; so does a surface that leads to a higher one (a staircase seen from its foot).
    floors = [0.0, nan, nan, 0.037, 0.037, 0.037, 0.037, 0.037, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[3, 1] == F
    floors = [0.0, nan, nan, 0.031, 0.031, 0.061, 0.061, 0.092, 0.092]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert types[3, 1] == F
    # Without the narrow rise (0 cells) the rim stays a floor.
    floors = [0.0, nan, nan, 0.037, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = surfaces_grid(floors)
    types, _ = fog(og, floor, band=BAND, beside=True, rise=0)
    assert types[3, 1] == F


def test_a_rim_over_a_lower_floor_under_its_own_spill_is_unknown():
    # The stage's box_right_2 in depth mode (seed 3): a rough top's low patch, a floor at
    # 0.163 (its own layer occupied), beside box-edge cells that hold the ground's floor under
    # the box's layers (top 0.18 > 0 + δ: an obstacle by eq. 11), and across from them box
    # cells holding the box's layer but no floor. The rim rule, which looks for a neighbour
    # labelled floor, left the patch a floor 57 mm below the box's true top. With
    # `rim_over_spill` a neighbour's stored floor more than the band below counts when its top
    # reaches no higher than this floor + δ and the raised floor ends across from it: unknown.
    nan = np.nan
    floors = [0.0, 0.0, 0.0, 0.163, nan, 0.0, 0.0]
    tops = [nan, nan, 0.17, nan, 0.17, nan, nan]
    og, floor = surfaces_grid(floors, tops_m=tops)
    types, heights = fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)
    assert types[:, 1].tolist() == [F, F, OB, U, OB, F, F]
    assert np.isnan(heights[3, 1])
    without, _ = fog(og, floor, band=BAND, beside=True, rise=RISE)
    assert without[:, 1].tolist() == [F, F, OB, F, OB, F, F]
    # A single raised cell between two such edge cells (a spill two cells wide, stereo):
    # along x the floor across is lower too, so the raised cell is no surface: unknown.
    floors = [0.0, 0.0, 0.0, 0.037, 0.0, 0.0, 0.0]
    tops = [nan, nan, 0.05, nan, 0.05, nan, nan]
    og, floor = surfaces_grid(floors, tops_m=tops)
    assert fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)[0][3, 1] == U
    assert fog(og, floor, band=BAND, beside=True, rise=RISE)[0][3, 1] == F
    # A cell across with no floor and only the ground's layer (a stereo sill's neighbour
    # whose floor no frame verified) is no end of the raised floor: a floor.
    og, floor = surfaces_grid(
        [0.0, 0.0, 0.0, 0.163, nan, 0.0, 0.0], tops_m=[nan, nan, 0.17, nan, 0.0, nan, nan]
    )
    assert fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)[0][3, 1] == F
    # Something taller than this floor + δ there (top 0.25 > 0.163 + 0.05) is no spill of
    # it: the rule leaves the floor beside it alone (the obstacle rule judges it).
    floors = [0.0, 0.0, 0.0, 0.163, nan, 0.0, 0.0]
    og, floor = surfaces_grid(floors, tops_m=[nan, nan, 0.25, nan, 0.17, nan, nan])
    assert fog(og, floor, band=BAND, beside=False, rise=RISE, spill=True)[0][3, 1] == F
    # Without the band the rule is off.
    og, floor = surfaces_grid(floors, tops_m=[nan, nan, 0.17, nan, 0.17, nan, nan])
    assert fog(og, floor, beside=True, rise=RISE, spill=True)[0][3, 1] == F


def test_a_riser_keeps_the_upper_treads_first_row_over_its_edge_cell():
    # A tread's riser in depth mode (talos_course: threshold, steps, platform; stairs): the
    # edge cell at the riser's foot holds the lower tread's floor under the upper tread's
    # layer (the riser's face, top 0.06 within 0.04 + δ), as a side spill's cell does. Across
    # from it the upper tread goes on (its floor within the band): its first row is a floor.
    # (Counting it gave up every tread's first row: talos_course floor recall −0.08 point.)
    floors = [0.0, 0.0, 0.0, 0.04, 0.04, 0.04, 0.04, 0.04, 0.04]
    tops = [np.nan, np.nan, 0.05] + [np.nan] * 6
    og, floor = surfaces_grid(floors, tops_m=tops)
    types, heights = fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)
    assert types[:, 1].tolist() == [F, F, OB, F, F, F, F, F, F]
    assert heights[3, 1] == 0.04
    # A staircase: treads 4 cells deep, each riser's edge cell spilled; every first row stays.
    floors = [0.0] * 3 + [0.08] * 4 + [0.16] * 4 + [0.24] * 4
    tops = [np.nan] * 15
    tops[2], tops[6], tops[10] = 0.09, 0.17, 0.25
    og, floor = surfaces_grid(floors, tops_m=tops)
    for ix in (2, 6, 10):  # the edge cells keep their lower floor
        floor[ix, :] = floors[ix - 1]
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)
    assert [types[ix, 1] for ix in (3, 7, 11)] == [F, F, F]
    assert np.array_equal(types, fog(og, floor, band=BAND, beside=True, rise=RISE)[0])


def test_a_spill_rim_across_a_diagonal_or_the_border():
    # Only the cell across from the spilled neighbour decides, along a diagonal too. A box
    # whose rough top left its layer (top 0.18) but no floor in every cell, but a patch at
    # 0.163 (the stage's box_right_2, seed 3), its corner cell (2, 2) holding the ground's
    # floor under the box's layers: the patch cell (3, 3) beside it diagonally is unknown when
    # the cell across, (4, 4), holds the layer but no floor; a floor when the patch goes on
    # there (a tread); at the grid's border nothing is across: a floor.
    def box(patch):
        og = np.full((7, 7, P.nz), 128, dtype=np.uint8)
        og[:, :, layer_of(0.0) : layer_of(0.17) + 1] = OCC
        floor = np.full((7, 7), np.nan)
        floor[2, 2] = 0.0
        for c in patch:
            og[c][: layer_of(0.163)] = 128
            floor[c] = 0.163
        return og, floor

    og, floor = box([(3, 3)])
    types, _ = fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)
    assert types[2, 2] == OB and types[3, 3] == U
    assert fog(og, floor, band=BAND, beside=True, rise=RISE)[0][3, 3] == F
    og, floor = box([(3, 3), (4, 4)])
    assert fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)[0][3, 3] == F
    nan = np.nan
    og, floor = surfaces_grid([0.0, 0.0, 0.0, 0.163], tops_m=[nan, nan, 0.17, nan])
    assert fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)[0][3, 1] == F


def test_a_narrow_surface_between_two_spilled_edge_cells_keeps_its_cells():
    # The room's sill in stereo: 2 cells deep (3, 4), its edge cells (2, 5) hold the ground's
    # floor under the sill's spill. Across the sill (the other side of each cell) the floors
    # drop within 4 cells: a narrow rise, whose rims the narrow-rise rules judge; the spill
    # rule leaves it alone (on: the sill's Table I row lost every cell on some seeds). Middle
    # row of 5 (the diagonals reach the ground past the sill's corners).
    nan = np.nan
    floors = [0.0, 0.0, 0.0, 0.037, 0.037, 0.0, 0.0, 0.0]
    tops = [nan, nan, 0.05, nan, nan, 0.05, nan, nan]
    og, floor = surfaces_grid(floors, ny=5, tops_m=tops)
    types, heights = fog(og, floor, band=BAND, beside=True, rise=RISE, spill=True)
    assert types[:, 2].tolist() == [F, F, OB, F, F, OB, F, F]
    assert heights[3, 2] == 0.037 and heights[4, 2] == 0.037


def test_narrow_rise_defaults_and_validation():
    assert P.narrow_rise_m == 0.16 and P.narrow_rise_cells == 4
    assert MapperParams(narrow_rise_m=0.0).narrow_rise_cells == 0
    assert MapperParams(narrow_rise_m=0.12, cell_m=0.04).narrow_rise_cells == 3
    for bad in (-0.01, float("nan"), float("inf")):
        with pytest.raises(InvalidParameterError, match="narrow_rise_m"):
            MapperParams(narrow_rise_m=bad)


def test_the_mapper_passes_narrow_rise_to_the_fog():
    # A sill 2 cells deep, seen straight down, flat: the ground cells at its feet are unknown
    # with the default, floor with narrow_rise_m = 0. (Seen by 3 frames only, the feet are
    # weak feet too: `edge_foot_min_frames` off, to see this rule alone.)
    labels = []
    for rise_m in (0.16, 0.0):
        params = MapperParams(narrow_rise_m=rise_m, edge_foot_min_frames=0)
        m = FloorObstacleMapper(params, center_xy_m=(0.0, 0.0))
        xs = np.arange(-0.4, 0.4, 0.01) + 0.005
        gx, gy = np.meshgrid(xs, xs, indexing="ij")
        gz = np.where((gx > 0.0) & (gx < 0.08), 0.037, 0.0)
        pts = np.stack([gx.ravel(), gy.ravel(), gz.ravel()], axis=1)
        for _ in range(3):
            m.update(pts, pts[:, 2].copy(), np.array([0.0, 0.0, 1.5]))
        labels.append(m.fog()[0])
    with_rule, without = labels
    ix_foot = m.cell_of(np.array([[-0.02, 0.0, 0.0], [0.10, 0.0, 0.0]]))[0][:, 0]
    iy = m.cell_of(np.array([[0.0, 0.0, 0.0]]))[0][0, 1]
    assert without[ix_foot, iy].tolist() == [F, F]
    assert with_rule[ix_foot, iy].tolist() == [U, U]


def test_the_rim_before_a_wide_shadow_is_unknown():
    # Platform (125 mm) | its points spilled a cell over its side edge (the zig-zag stage's
    # drift) | two cells of ground hidden behind the edge: nothing stored | the ground seen
    # beyond. The band's shadow rule sees one empty cell only: the spilled cell stays a floor
    # 125 mm above the truth. With a reach of 2 cells or more it is unknown; the platform's
    # cells behind it are not (their run of empty cells starts no neighbour away).
    nan = np.nan
    og, floor = surfaces_grid([0.125, 0.125, 0.125, nan, nan, 0.0, 0.0])
    assert fog(og, floor, band=BAND)[0][:, 1].tolist() == [F, F, F, U, U, F, F]
    for shadow in (2, 4):
        types, _ = fog(og, floor, band=BAND, shadow=shadow)
        assert types[:, 1].tolist() == [F, F, U, U, U, F, F]
    # A shadow wider than the reach, a floor or obstacle in the run, or no lower floor at its
    # end: left to the band's rule. A reach of 1 cell is that rule alone.
    og_wide, floor_wide = surfaces_grid([0.125, 0.125, 0.125, nan, nan, nan, 0.0])
    assert fog(og_wide, floor_wide, band=BAND, shadow=2)[0][2, 1] == F
    assert fog(og_wide, floor_wide, band=BAND, shadow=3)[0][2, 1] == U
    og_obst, floor_obst = surfaces_grid(
        [0.125, 0.125, 0.125, nan, nan, 0.0], tops_m=[nan, nan, nan, 0.3, nan, nan]
    )
    assert fog(og_obst, floor_obst, band=BAND, shadow=4)[0][2, 1] == F
    og_high, floor_high = surfaces_grid([0.125, 0.125, 0.125, nan, nan, 0.11])
    assert fog(og_high, floor_high, band=BAND, shadow=4)[0][2, 1] == F
    assert fog(og, floor, band=BAND, shadow=1)[0][2, 1] == F
    assert fog(og, floor, shadow=4)[0][:, 1].tolist() == [F, F, F, U, U, F, F]  # no band: off


def test_a_wide_shadow_along_a_diagonal_and_relabelled_from_afar():
    # The lower floor at the end of a diagonal run of empty cells; and an update of only the
    # cell where that floor appears relabels the rim 3 cells away as a whole-grid update does.
    n = 6
    og = np.full((n, n, P.nz), 128, dtype=np.uint8)
    floor = np.full((n, n), np.nan)
    og[0, 0, layer_of(0.125)] = OCC
    floor[0, 0] = 0.125
    types, _ = fog(og, floor, band=BAND, shadow=4)
    assert types[0, 0] == F
    og[3, 3, layer_of(0.0)] = OCC
    floor[3, 3] = 0.0
    part, _ = fog(og, floor, area=(3, 4, 3, 4), types=types.copy(), band=BAND, shadow=4)
    whole, _ = fog(og, floor, band=BAND, shadow=4)
    assert part[0, 0] == U and np.array_equal(part, whole)


def test_shadow_reach_defaults_and_validation():
    assert P.shadow_reach_m == 0.16 and P.shadow_reach_cells == 4
    assert MapperParams(shadow_reach_m=0.0).shadow_reach_cells == 0
    assert P.min_floor_neighbours == 0
    with pytest.raises(InvalidParameterError, match="min_floor_neighbours"):
        MapperParams(min_floor_neighbours=-1)
    for bad in (-0.01, float("nan"), float("inf")):
        with pytest.raises(InvalidParameterError, match="shadow_reach_m"):
            MapperParams(shadow_reach_m=bad)


def _rough_top(patch_cells):
    """A 7 × 7 box whose rough top left an obstacle (top 0.22) in every cell but
    ``patch_cells``, where a floor at 0.20 was fitted (its own layer occupied), in a 9 × 9 grid
    of ground."""
    og = np.full((9, 9, P.nz), 128, dtype=np.uint8)
    floor = np.full((9, 9), 0.0)
    og[:, :, layer_of(0.0)] = OCC
    floor[1:8, 1:8] = np.nan
    og[1:8, 1:8, layer_of(0.0) : layer_of(0.21) + 1] = OCC
    for ix, iy in patch_cells:
        og[ix, iy, :] = 128
        og[ix, iy, layer_of(0.0)] = OCC
        og[ix, iy, layer_of(0.20)] = OCC
        floor[ix, iy] = 0.20
    return og, floor


def test_a_floor_patch_inside_a_taller_obstacle_is_unknown():
    # One or two cells of floor at 0.20 inside a box whose other cells are obstacles (eq. 10's
    # top 0.22, the floor's own layer): floors to the band's rules (nothing lower beside them,
    # the obstacles less than δ above), unknown with 2 floor neighbours wanted; a patch of
    # three in a row keeps its middle cell (2 floor neighbours), and 1 wanted keeps the pair.
    for patch in ([(4, 4)], [(4, 4), (4, 5)]):
        og, floor = _rough_top(patch)
        types, _ = fog(og, floor, band=BAND, beside=True)
        assert all(types[c] == F for c in patch)
        types, heights = fog(og, floor, band=BAND, beside=True, island=2)
        assert all(types[c] == U for c in patch) and all(np.isnan(heights[c]) for c in patch)
        assert types[2, 2] == OB  # the box
    og, floor = _rough_top([(4, 3), (4, 4), (4, 5)])
    types, _ = fog(og, floor, band=BAND, beside=True, island=2)
    assert [types[4, k] for k in (3, 4, 5)] == [U, F, U]
    og, floor = _rough_top([(4, 4), (4, 5)])
    types, _ = fog(og, floor, band=BAND, beside=True, island=1)
    assert types[4, 4] == F and types[4, 5] == F


def test_a_floor_with_few_floor_neighbours_but_nothing_taller_stays_floor():
    # A single ground cell seen among unknown cells (far, sparse ground): no taller obstacle
    # beside it, a floor; without the band the rule is off.
    og = np.full((3, 3, P.nz), 128, dtype=np.uint8)
    floor = np.full((3, 3), np.nan)
    og[1, 1, layer_of(0.0)] = OCC
    floor[1, 1] = 0.0
    assert fog(og, floor, band=BAND, island=2)[0][1, 1] == F
    og, floor = _rough_top([(4, 4)])
    assert fog(og, floor, island=2)[0][4, 4] == F


def test_the_patch_rule_relabels_as_a_whole_grid_update_would():
    # A row of three floor cells keeps its middle one; when the last turns obstacle, updating
    # only that cell (the obstacle map kept from the whole-grid update: eq. 10 outside the area
    # is current) relabels the middle one exactly as a whole-grid update does.
    og, floor = _rough_top([(4, 3), (4, 4), (4, 5)])
    nx, ny = floor.shape
    obstacle = np.full((nx, ny), np.nan)
    zeros = np.zeros((nx, ny), dtype=np.int32)

    def update(area, types):
        heights = np.full((nx, ny), -1.0)
        update_fog_area(
            og, floor, obstacle, types, heights, P.occ_threshold_level, Z0, L, P.delta_m,
            *area, zeros, zeros, P.floor_pass_min_rays, P.floor_pass_fraction,
            0, BAND, True, 0, 0, 2,
        )  # fmt: skip
        return types

    types = update((0, nx, 0, ny), np.full((nx, ny), -1, dtype=np.int8))
    assert types[4, 4] == F
    og[4, 5, :] = 128
    og[4, 5, layer_of(0.0) : layer_of(0.21) + 1] = OCC
    floor[4, 5] = np.nan
    part = update((4, 5, 5, 6), types.copy())
    whole = update((0, nx, 0, ny), np.full((nx, ny), -1, dtype=np.int8))
    assert part[4, 4] == U and np.array_equal(part, whole)


def test_rim_over_spill_is_on_by_default_and_the_mapper_passes_it(monkeypatch):
    # A 60 mm box top 0.40 × 0.20 m (10 × 5 cells) on the ground, seen straight down: its
    # edge cells hold the ground's floor under the box's layer (an obstacle by eq. 11, its top
    # 0.10 within 0.0615 + δ), and across from them the box top goes on: its rim cells stay
    # floors either way (as a tread's first row does). The mapper hands the switch to the FOG.
    assert P.rim_over_spill is True
    with pytest.raises(InvalidParameterError, match="rim_over_spill"):
        MapperParams(rim_over_spill=1)
    xs, ys = np.meshgrid(np.arange(0.205, 1.0, 0.01), np.arange(-0.395, 0.4, 0.01), indexing="ij")
    xs, ys = xs.ravel(), ys.ravel()
    on_box = (xs > 0.40) & (xs < 0.80) & (ys > 0.10) & (ys < 0.30)
    z = np.where(on_box, 0.0615, 0.0)
    points = np.column_stack([xs, ys, z])
    passed = []

    def spy(*args):
        passed.append(args[-3])  # rim_over_spill, before rim_over_seen_drop and ground_noise
        return update_fog_area(*args)

    monkeypatch.setattr("mapper.mapper.update_fog_area", spy)
    floors = {}
    for on in (False, True):
        m = FloorObstacleMapper(MapperParams(rim_over_spill=on))
        for _ in range(10):
            m.update(points, z.copy(), np.array([0.0, 0.0, 1.5]))
        types, heights = m.fog()
        floors[on] = (types == F) & (np.abs(heights - 0.0615) < 0.01)
    assert passed == [False, True]  # the FOG is computed once, when read
    assert floors[True].sum() > 0 and np.array_equal(floors[True], floors[False])
