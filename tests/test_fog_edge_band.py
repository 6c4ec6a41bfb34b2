"""The FOG's edge band (`MapperParams.edge_band_m`) on hand-built grids.

The rule (`mapper.fog`): a cell eq. 11 and the cover check label floor at ``h_f`` is unknown
when one of its 8 neighbours is labelled floor more than ``band`` above or below ``h_f``, or
obstacle with a height more than δ above ``h_f``. With the default grid (z_min −0.06 m, layers
of 0.04 m, δ 0.05 m) a surface at h lies in layer ``floor((h + 0.06) / 0.04)``, so an obstacle
column occupied up to layer k has the top ``z_min + (k + 1)·0.04``.
"""

import numpy as np
import pytest

from mapper import CellType, InvalidParameterError, MapperParams
from mapper.fog import update_fog_area

P = MapperParams()
Z0, L = P.z_min_m, P.layer_m
OCC = 230
BAND = 0.02
F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN


def layer_of(h):
    return int(np.floor((h - Z0) / L))


def grid(floors_m, tops_m=None, ny=3):
    """A (n, ny) grid, every row alike: column ix holds a floor at ``floors_m[ix]`` (NaN: none)
    and, where ``tops_m[ix]`` is given, occupied layers from the floor's (or the ground's) up to
    the one holding that top (an obstacle)."""
    n = len(floors_m)
    tops_m = tops_m or [np.nan] * n
    og = np.full((n, ny, P.nz), 128, dtype=np.uint8)
    floor = np.full((n, ny), np.nan)
    for ix, (h, top) in enumerate(zip(floors_m, tops_m, strict=True)):
        if np.isfinite(h):
            og[ix, :, layer_of(h)] = OCC
            floor[ix, :] = h
        if np.isfinite(top):
            og[ix, :, layer_of(0.0) : layer_of(top) + 1] = OCC
    return og, floor


def fog(og, floor, band, area=None, types=None, passes=None, ends=None):
    """Types and heights after `update_fog_area` over ``area`` (default: the whole grid);
    ``types`` pre-fills the FOG (default −1: no label, to see which cells were written)."""
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
        0, band,
    )  # fmt: skip
    return types, heights


def test_sill_whose_near_edge_cell_took_the_sill_height():
    # x: ground, ground, the sill's near edge cell (a quarter sill: its sill points won the
    # votes), sill, sill, the far edge cell (3/4 ground: ground won), ground, ground. The truth
    # makes both edge cells obstacles; the paper's FOG makes every cell a floor at its height,
    # the near edge cell 37 mm off the ground under most of it.
    floors = [0.0, 0.0, 0.037, 0.037, 0.037, 0.0, 0.0, 0.0]
    og, floor = grid(floors)
    types, heights = fog(og, floor, BAND)
    # Jumps of 37 mm between cells 1|2 and 4|5: the four cells beside them are unknown.
    assert types[:, 1].tolist() == [F, U, U, F, U, U, F, F]
    assert np.isnan(heights[[1, 2, 4, 5], 1]).all()
    assert heights[3, 1] == 0.037 and heights[0, 1] == 0.0
    types0, heights0 = fog(og, floor, 0.0)  # the paper
    assert types0[:, 1].tolist() == [F] * 8 and np.array_equal(heights0, floor)


def test_jumps_within_the_band_stay_floor():
    # Steps of 20 mm (not more than the band: floor), 21 mm (unknown on both sides), and
    # the diagonal neighbour counts as much as the others.
    og, floor = grid([0.0, 0.02, 0.02, 0.041, 0.041])
    types, _ = fog(og, floor, BAND)
    assert types[:, 1].tolist() == [F, F, U, U, F]
    og, floor = grid([0.0, 0.0, 0.0], ny=3)
    floor[2, 2] = 0.03  # one cell, its diagonal neighbour (1, 1)
    types, _ = fog(og, floor, BAND)
    assert types[1, 1] == U and types[0, 0] == F and types[2, 2] == U
    assert types[0, 2] == F  # two cells from (2, 2)


def test_floor_beside_an_obstacle_more_than_delta_above_it():
    # A rough box (no floor, occupied from the ground to layer 7: top 0.26) between ground
    # cells: its neighbours are unknown, it stays an obstacle at its top, cells two away floor.
    nan = np.nan
    og, floor = grid([0.0, 0.0, nan, 0.0, 0.0], [nan, nan, 0.25, nan, nan])
    types, heights = fog(og, floor, BAND)
    assert types[:, 1].tolist() == [F, U, OB, U, F]
    assert heights[2, 1] == pytest.approx(Z0 + (layer_of(0.25) + 1) * L) == pytest.approx(0.26)


def test_obstacle_within_delta_of_the_higher_floor_bands_only_the_lower():
    # Ground | a riser cell seen as an obstacle (top 0.14) | the 122 mm platform: 0.14 is more
    # than δ above the ground but not above 0.122 + 0.05, so the platform stays floor.
    nan = np.nan
    og, floor = grid([0.0, 0.0, nan, 0.122, 0.122], [nan, nan, 0.12, nan, nan])
    types, _ = fog(og, floor, BAND)
    assert types[:, 1].tolist() == [F, U, OB, F, F]


def test_neighbour_the_cover_check_makes_unknown_bands_nothing():
    # Cell 2 holds a 37 mm floor passed by 10 of 30 rays (> 0.2): unknown, so it is no edge
    # for its neighbours, which stay floor.
    og, floor = grid([0.0, 0.0, 0.037, 0.0, 0.0])
    ends = np.zeros(floor.shape, dtype=np.int32)
    passes = np.zeros(floor.shape, dtype=np.int32)
    ends[2, :], passes[2, :] = 20, 10
    types, _ = fog(og, floor, BAND, ends=ends, passes=passes)
    assert types[:, 1].tolist() == [F, F, U, F, F]


def test_ring_around_the_area_is_relabelled_as_a_whole_grid_update_would():
    # A 61 mm strip three cells wide (cells 3-5); only cell 4 changed (area [4, 5) x all rows).
    # Its ring, cells 3 and 5, is relabelled too (beside the ground: unknown), cell 4 between
    # two floors of its own height is floor; cells two away are left as they were (-1). The
    # whole-grid update gives the same labels: the neighbours' labels come from the maps, not
    # from the FOG being written.
    og, floor = grid([0.0, 0.0, 0.0, 0.061, 0.061, 0.061, 0.0, 0.0, 0.0])
    types, heights = fog(og, floor, BAND, area=(4, 5, 0, 3))
    assert types[:, 1].tolist() == [-1, -1, -1, U, F, U, -1, -1, -1]
    assert heights[4, 1] == 0.061
    full, _ = fog(og, floor, BAND)
    assert np.array_equal(full[3:6], types[3:6])
    assert full[:, 1].tolist() == [F, F, U, U, F, U, U, F, F]


@pytest.mark.parametrize("band", [-0.01, float("nan"), float("inf")])
def test_band_validated(band):
    with pytest.raises(InvalidParameterError, match="edge_band_m"):
        MapperParams(edge_band_m=band)


def test_band_default():
    assert P.edge_band_m == 0.02
