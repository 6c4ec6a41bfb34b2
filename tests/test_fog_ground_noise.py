"""No obstacle within δ of the floor around it (`MapperParams.ground_noise_unknown`).

Eq. 11 makes a cell without a floor an obstacle as soon as any of its layers is occupied, and a
cell whose own floor is low an obstacle when its top is δ (0.05 m) above that floor. With the
rule such a cell is unknown when its top (eq. 10) lies at most δ above the lowest floor of its 8
neighbours that eq. 11 leaves a floor, at least 3 of them. With the default grid (z_min −0.06 m,
layers of 0.04 m) the ground at 0 sits in layer 1 (−0.02–0.02, top 0.02) and layer 2 (top 0.06)
lies more than δ above it.
"""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from tests.test_fog_margin import OCC, fog, layer_of, surfaces_grid

P = MapperParams()
F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN


def fog_row(og, floor, ground_noise=True):
    """Labels and heights of row y = 1 after `update_fog_area` with the default rules."""
    types, heights = fog_defaults(og, floor, ground_noise)
    return types[:, 1].tolist(), heights[:, 1]


def fog_defaults(og, floor, ground_noise):
    """Types and heights of the whole grid with the default rules and ``ground_noise``."""
    return fog(
        og, floor, margin=P.obstacle_margin_cells, band=P.edge_band_m,
        beside=P.unknown_beside_obstacles, rise=P.narrow_rise_cells, shadow=P.shadow_reach_cells,
        island=P.min_floor_neighbours, spill=P.rim_over_spill, seen_drop=P.rim_over_seen_drop,
        ground_noise=ground_noise,
    )  # fmt: skip


def ground_with(cell_floor_m=np.nan, occupied_layers=(1,)):
    """x: seven cells of ground at 0; cell 3 holds ``cell_floor_m`` (NaN: no floor) and the
    ``occupied_layers`` (its floor's layer too)."""
    og, floor = surfaces_grid([0.0] * 3 + [cell_floor_m] + [0.0] * 3)
    og[3, :, :] = 128
    for k in occupied_layers:
        og[3, :, k] = OCC
    return og, floor


def test_ground_hits_without_a_floor_are_unknown_not_an_obstacle():
    og, floor = ground_with(occupied_layers=(1,))  # top 0.02: the ground's own layer
    assert fog_row(og, floor)[0] == [F, F, F, U, F, F, F]
    types, heights = fog_row(og, floor, ground_noise=False)
    assert types == [F, F, F, OB, F, F, F]  # eq. 11: a missing floor counts any top
    assert heights[3] == pytest.approx(0.02)


def test_a_floor_lower_than_every_neighbour_with_ground_hits_is_unknown():
    # Own floor −0.04 (layer 0), hits in the ground's layer: top 0.02 > −0.04 + δ (eq. 11: an
    # obstacle), but 0.02 ≤ 0 + δ above the floor around it.
    og, floor = ground_with(cell_floor_m=-0.04, occupied_layers=(0, 1))
    floor[3, [0, 2]] = np.nan  # the low floor in row 1 alone: its neighbours are the ground
    assert fog_row(og, floor, ground_noise=False)[0][3] == OB
    assert fog_row(og, floor)[0][3] == U


def test_a_top_more_than_delta_above_the_floor_around_stays_an_obstacle():
    og, floor = ground_with(occupied_layers=(1, 2))  # top 0.06 > 0 + 0.05
    types, heights = fog_row(og, floor)
    assert types[3] == OB
    assert heights[3] == pytest.approx(0.06)


def test_the_lowest_neighbouring_floor_decides():
    # A 125 mm platform (cells 0-2) beside the ground (4-6); cell 3 between them holds no
    # floor and layers up to the platform's (top 0.14): 0.14 ≤ 0.125 + δ, but the ground
    # beside it is the lowest floor around: the platform's side, an obstacle.
    og, floor = surfaces_grid(
        [0.125] * 3 + [np.nan] + [0.0] * 3, tops_m=[np.nan] * 3 + [0.125] + [np.nan] * 3
    )
    assert fog_row(og, floor)[0][3] == OB
    # Amid the platform the same column is noise on the platform's layer.
    og, floor = surfaces_grid([0.125] * 7)
    floor[3, :] = np.nan
    og[3, :, :] = 128
    og[3, :, layer_of(0.125)] = OCC
    assert fog_row(og, floor)[0] == [F, F, F, U, F, F, F]


def test_a_floor_with_something_on_it_is_no_floor_around():
    # Cells 0-2: a floor stored at 0.25 under layers up to 0.30 (an obstacle by eq. 11: a plane
    # fitted on a box's side); cell 3 holds no floor and layers up to 0.25 (top 0.26, within
    # δ of 0.25): the only floors around it are no floors, so eq. 11 stands.
    og, floor = surfaces_grid([0.25] * 3 + [np.nan] * 4, tops_m=[0.30] * 3 + [0.25] + [np.nan] * 3)
    types, heights = fog_row(og, floor)
    assert types[:4] == [OB, OB, OB, OB]
    assert heights[3] == pytest.approx(0.26)


def test_three_floors_around_are_needed():
    # Every cell holds ground-layer hits and no floor but the floors given at x = 2: cell
    # (3, 1) has two, then three floors around it.
    og, floor = surfaces_grid([np.nan] * 7, tops_m=[0.0] * 7)
    floor[2, 0] = floor[2, 1] = 0.0
    assert fog_row(og, floor)[0][3] == OB
    floor[2, 2] = 0.0
    assert fog_row(og, floor)[0][3] == U


def test_inside_an_obstacle_no_floor_around_leaves_eq_11():
    # Cells 2-4 hold ground-layer hits and no floor: 3's neighbours hold none, so it stays an
    # obstacle; 2 and 4 have the ground beside them.
    og, floor = surfaces_grid([0.0] * 2 + [np.nan] * 3 + [0.0] * 2)
    og[2:5, :, :] = 128
    og[2:5, :, 1] = OCC
    assert fog_row(og, floor)[0] == [F, F, U, OB, U, F, F]


def test_default_validation_and_the_mapper_passes_it():
    assert MapperParams().ground_noise_unknown is True
    with pytest.raises(InvalidParameterError, match="ground_noise_unknown"):
        MapperParams(ground_noise_unknown=1)
    # The ground at 0 seen straight down, then hits in the ground's layer of one cell whose
    # floor is withdrawn (as for ground the segmentation left unlabelled).
    labels = []
    for on in (True, False):
        m = FloorObstacleMapper(MapperParams(ground_noise_unknown=on), center_xy_m=(0.0, 0.0))
        xs = np.arange(-0.4, 0.4, 0.01) + 0.005
        gx, gy = np.meshgrid(xs, xs, indexing="ij")
        pts = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
        m.update(pts, pts[:, 2].copy(), np.array([0.0, 0.0, 1.5]))
        ix, iy = m.cell_of(np.array([[0.1, 0.1, 0.0]]))[0][0, :2]
        m._floor[ix, iy] = np.nan
        cells = m.cell_of(pts)[0]
        inside = (cells[:, 0] == ix) & (cells[:, 1] == iy)
        floor_heights = np.where(inside, np.nan, pts[:, 2])  # its points labelled no floor
        m.update(pts, floor_heights, np.array([0.0, 0.0, 1.5]))
        labels.append(m.fog()[0][ix, iy])
    assert labels == [U, OB]


def test_the_rule_only_takes_obstacles_to_unknown_on_random_grids():
    # The rim rules see eq. 11's obstacles: a rim beside a noise cell stays unknown, so the
    # rule never adds a floor (nor an obstacle) anywhere.
    rng = np.random.default_rng(7)
    heights = np.array([np.nan, 0.0, 0.0, 0.0, -0.04, 0.03, 0.125])
    changed = 0
    for _ in range(200):
        nx, ny = 8, 6
        floor = rng.choice(heights, size=(nx, ny))
        og = np.full((nx, ny, P.nz), 128, dtype=np.uint8)
        for ix, iy in np.ndindex(nx, ny):
            if np.isfinite(floor[ix, iy]):
                og[ix, iy, layer_of(floor[ix, iy])] = OCC
            top = rng.choice([-1, -1, 1, 2, 4, 5])
            if top >= 0:
                og[ix, iy, 1 : top + 1] = OCC
        types = {on: fog_defaults(og, floor, on)[0] for on in (False, True)}
        diff = types[False] != types[True]
        assert np.all(types[False][diff] == OB) and np.all(types[True][diff] == U)
        changed += int(diff.sum())
    assert changed > 50  # the rule fires on these grids
