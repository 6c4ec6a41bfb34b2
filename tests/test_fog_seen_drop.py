"""The rim before a drop seen as free space (`MapperParams.rim_over_seen_drop`, `mapper.fog`).

A floor at ``h`` is unknown when one of its 8 neighbours holds nothing (no floor, no obstacle)
and a layer of that neighbour's column whose top lies more than the band (0.02 m) below ``h``
was observed free (level < 128).
With the default grid (z_min −0.06 m, layers of 0.04 m) layer k spans
``[−0.06 + 0.04·k, −0.02 + 0.04·k]``: under the 125 mm platform (layer 4, 0.10–0.14) lie layers
0–3 (top 0.10 < 0.105); under the ground at 0 none (layer 0's top is −0.02, and the ground
sits in layer 1, −0.02–0.02: layer 0's top is not more than the band, 0.02, below 0).
"""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.fog import update_fog_area
from tests.test_fog_margin import OCC, surfaces_grid

P = MapperParams()
F, U = CellType.FLOOR, CellType.UNKNOWN
FREE = 60  # a level observed free (< 128)


def fog_row(og, floor, seen_drop=True, area=None):
    """Labels of row y = 1 after `update_fog_area` with the default band rules."""
    nx, ny = floor.shape
    ix0, ix1, iy0, iy1 = area or (0, nx, 0, ny)
    types = np.full((nx, ny), -1, dtype=np.int8)
    heights = np.full((nx, ny), -1.0)
    obstacle = np.full((nx, ny), np.nan)
    zeros = np.zeros((nx, ny), dtype=np.int32)
    update_fog_area(
        og, floor, obstacle, types, heights, P.occ_threshold_level, P.z_min_m, P.layer_m,
        P.delta_m, ix0, ix1, iy0, iy1, zeros, zeros, P.floor_pass_min_rays,
        P.floor_pass_fraction, P.obstacle_margin_cells, P.edge_band_m,
        P.unknown_beside_obstacles, P.narrow_rise_cells, P.shadow_reach_cells,
        P.min_floor_neighbours, P.rim_over_spill, seen_drop,
    )  # fmt: skip
    return types[:, 1].tolist()


def platform_beside_the_unseen(free_layers):
    """x: five cells of a 125 mm platform, then six cells where nothing is stored whose
    columns have ``free_layers`` observed free (the shadow behind its side edge)."""
    og, floor = surfaces_grid([0.125] * 5 + [np.nan] * 6)
    for k in free_layers:
        og[5:, :, k] = FREE
    return og, floor


def test_the_rim_before_free_space_below_it_is_unknown():
    og, floor = platform_beside_the_unseen(free_layers=[3])  # 0.06–0.10, under 0.125
    assert fog_row(og, floor) == [F, F, F, F, U] + [U] * 6
    assert fog_row(og, floor, seen_drop=False) == [F] * 5 + [U] * 6


@pytest.mark.parametrize(
    "free_layers",
    [
        [],  # never seen: no evidence (the rule does not erode a map's border)
        [4, 5, 6],  # free only in the platform's own layer and above: a surface may go on
    ],
)
def test_no_free_layer_below_the_surface_keeps_the_rim(free_layers):
    og, floor = platform_beside_the_unseen(free_layers)
    assert fog_row(og, floor) == [F] * 5 + [U] * 6


def test_a_neighbour_with_an_obstacle_or_a_floor_is_no_drop():
    # The free layer below, but the column also holds an obstacle (occupied layer 2, top 0.06,
    # lower than the platform: no rule of its own fires) or a floor.
    og, floor = platform_beside_the_unseen(free_layers=[1])
    og[5, :, 2] = OCC
    assert fog_row(og, floor)[:5] == [F] * 5
    og, floor = platform_beside_the_unseen(free_layers=[2])
    floor[5, :] = 0.127
    og[5, :, 4] = OCC
    assert fog_row(og, floor)[:6] == [F] * 5 + [U]  # the platform goes on: its rim moves on


def test_the_ground_beside_unseen_cells_stays_floor():
    # Only layer 0 (top −0.02) lies under the ground's layer, not more than the band (0.02)
    # below a ground at 0: rays to noisy points under the ground clear it; free space above
    # the ground (layers 1 and up) says nothing either.
    og, floor = surfaces_grid([0.0] * 5 + [np.nan] * 6)
    og[5:, :, :] = FREE
    assert fog_row(og, floor) == [F] * 5 + [U] * 6


def test_a_diagonal_neighbour_counts_and_an_update_beside_relabels_the_rim():
    og, floor = platform_beside_the_unseen(free_layers=[])
    types = fog_row(og, floor)
    assert types[4] == F
    # A frame's rays free layer 3 of the empty cell (5, 0) only: the rim (4, 1) is its
    # diagonal neighbour, relabelled though the frame's area is that cell alone.
    og[5, 0, 3] = FREE
    assert fog_row(og, floor, area=(5, 6, 0, 1))[4] == U


def test_default_validation_and_the_mapper_passes_it():
    assert MapperParams().rim_over_seen_drop is True
    with pytest.raises(InvalidParameterError, match="rim_over_seen_drop"):
        MapperParams(rim_over_seen_drop=1)
    # A 125 mm platform (x < 0) seen straight down, nothing beyond it; then the columns just
    # beyond its edge are marked free under its top, as rays into a shadow below it would, and
    # the platform seen again: its rim is unknown with the rule, a floor without.
    labels = []
    for on in (True, False):
        m = FloorObstacleMapper(MapperParams(rim_over_seen_drop=on), center_xy_m=(0.0, 0.0))
        xs = np.arange(-0.4, 0.0, 0.01) + 0.005
        gx, gy = np.meshgrid(xs, np.arange(-0.4, 0.4, 0.01) + 0.005, indexing="ij")
        pts = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.125)], axis=1)
        m.update(pts, pts[:, 2].copy(), np.array([-0.2, 0.0, 1.5]))
        ix_beyond = m.cell_of(np.array([[0.02, 0.0, 0.0]]))[0][0, 0]
        m._og[ix_beyond, :, 2] = FREE
        m.update(pts, pts[:, 2].copy(), np.array([-0.2, 0.0, 1.5]))
        labels.append(m.fog()[0])
    with_rule, without = labels
    ix_rim, iy = m.cell_of(np.array([[-0.02, 0.0, 0.0]]))[0][0, :2]
    assert without[ix_rim, iy] == F
    assert with_rule[ix_rim, iy] == U
    assert with_rule[ix_rim - 1, iy] == F
