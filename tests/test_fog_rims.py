"""Raised rims (`MapperParams.raised_rim_obstacle`, `mapper.fog.mark_raised_rims`), by hand.

A floor at ``h`` beside a cell whose stored floor lies more than δ below ``h`` and whose column
reaches at most ``h + δ`` (eq. 10's top ``z_min + (k + 1)·layer`` of its highest occupied layer
k; none counts as low) is an obstacle with its own column's top. Default grid: z_min −0.06 m,
layers of 0.04 m, δ 0.05 m; a 60 mm box top's points lie in layer 3 (top 0.10) once noise lifts
them over 0.06.
"""

import numpy as np
import pytest

from mapper import CellType, FloorObstacleMapper, InvalidParameterError, MapperParams
from mapper.floor_edges import mark_floor_edges
from mapper.fog import mark_raised_rims, update_fog_area

P = MapperParams()
Z0, L, DELTA = P.z_min_m, P.layer_m, P.delta_m
OCC = 230
F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN


def layer_of(h):
    return int(np.floor((h - Z0) / L))


def grid(floors_m, tops_m, ny=3):
    """(n, ny) grid, every row alike: column ix a floor at ``floors_m[ix]`` (NaN: none) with
    its layer occupied, and layers up to the one holding ``tops_m[ix]`` occupied (NaN: none)."""
    n = len(floors_m)
    og = np.full((n, ny, P.nz), 128, dtype=np.uint8)
    floor = np.full((n, ny), np.nan)
    for ix, (h, top) in enumerate(zip(floors_m, tops_m, strict=True)):
        if np.isfinite(h):
            og[ix, :, layer_of(h)] = OCC
            floor[ix, :] = h
        if np.isfinite(top):
            og[ix, :, layer_of(top)] = OCC
    return og, floor


def fog(og, floor, rims):
    """FOG labels and heights of the whole grid, the paper's eq. 11 (no band, no margin), then
    the rim rule over the whole grid when ``rims``."""
    nx, ny = floor.shape
    types = np.full((nx, ny), -1, dtype=np.int8)
    heights = np.full((nx, ny), -1.0)
    obstacle = np.full((nx, ny), np.nan)
    zeros = np.zeros((nx, ny), dtype=np.int32)
    update_fog_area(
        og, floor, obstacle, types, heights, P.occ_threshold_level, Z0, L, DELTA,
        0, nx, 0, ny, zeros, zeros, P.floor_pass_min_rays, P.floor_pass_fraction, 0, 0.0, False,
    )  # fmt: skip
    changed = mark_raised_rims(floor, obstacle, types, heights, DELTA, 0, nx, 0, ny) if rims else 0
    return types, heights, changed


def test_box_rim_beside_its_edge_cell_is_obstacle():
    # ground | the box's edge cell (ground floor, box-top points in layer 3: top 0.10 > 0 + δ)
    # | box top 0.06 (its points in layer 3 too: 0.10 <= 0.06 + δ, a floor by eq. 11) | box
    # top | box top | ground. The first top cell has the edge cell beside it (0 < 0.06 − δ,
    # 0.10 <= 0.06 + δ), the last the ground (0 < 0.06 − δ, top 0.02): both rims, obstacles
    # at their own top 0.10. The middle top cell has no lower floor beside it.
    og, floor = grid(
        [0.0, 0.0, 0.06, 0.06, 0.06, 0.0], [np.nan, 0.062, 0.062, 0.062, 0.062, np.nan]
    )
    types, heights, changed = fog(og, floor, rims=True)
    assert types[:, 1].tolist() == [F, OB, OB, F, OB, F]
    assert heights[:, 1] == pytest.approx([0.0, 0.10, 0.10, 0.06, 0.10, 0.0])
    assert changed == 6  # two rim cells per row
    # Off (the paper): the rim is the box top's floor.
    types0, heights0, _ = fog(og, floor, rims=False)
    assert types0[:, 1].tolist() == [F, OB, F, F, F, F]
    assert heights0[2, 1] == 0.06


def test_low_rise_and_tall_obstacle_leave_the_floor():
    # A sill (38 mm, rise <= δ): the ground's floor 0 is not more than δ below 0.038, so its
    # rim stays floor. A tall box (top 0.26) beside a 60 mm top: more than δ above it, no
    # edge of this floor (eq. 11's own business, not the rim rule's).
    og, floor = grid([0.0, 0.038, 0.038], [0.04, 0.04, np.nan])
    types, _, changed = fog(og, floor, rims=True)
    assert types[:, 1].tolist() == [OB, F, F] and changed == 0
    og, floor = grid([0.0, 0.06, 0.06], [0.25, np.nan, np.nan])
    types, _, changed = fog(og, floor, rims=True)
    assert types[:, 1].tolist() == [OB, F, F] and changed == 0


def test_diagonal_edge_cell_and_nan_neighbours():
    # A 3 × 3 grid of box top (0.06) whose corner (0, 0) is the edge cell; cells with nothing
    # stored around it are no edge cells (NaN compares false).
    og, floor = grid([0.06, 0.06, 0.06], [np.nan] * 3)
    og[0, 0, :] = 128
    og[0, 0, layer_of(0.0)] = OCC
    og[0, 0, layer_of(0.062)] = OCC
    floor[0, 0] = 0.0
    floor[2, 2] = np.nan
    og[2, 2, :] = 128
    types, heights, _ = fog(og, floor, rims=True)
    expected = np.full((3, 3), F)
    expected[0, 0] = OB  # the edge cell itself (eq. 11)
    expected[:2, :2] = OB  # and its three neighbours, (1, 1) diagonal
    expected[2, 2] = U
    assert np.array_equal(types, expected)
    assert heights[1, 1] == pytest.approx(0.10)


def _box_points(offset_y_m):
    """A 60 mm box top over x 0.40–0.80, y 0.10+offset–0.30+offset, and the ground around it
    on a 1 cm lattice, seen from above; floor heights for every point."""
    xs, ys = np.meshgrid(np.arange(0.205, 1.0, 0.01), np.arange(-0.395, 0.4, 0.01), indexing="ij")
    xs, ys = xs.ravel(), ys.ravel()
    on_box = (xs > 0.40) & (xs < 0.80) & (ys > 0.10 + offset_y_m) & (ys < 0.30 + offset_y_m)
    z = np.where(on_box, 0.0615, 0.0)
    points = np.column_stack([xs, ys, z])
    return points, z.copy()


def test_mapper_switch_and_check():
    # The mapper with the rule on marks the box top's rim cells beside the edge cells; off, the
    # same frames give the paper's FOG with the box top a floor to its edge. (The rim rule
    # over spilled edge cells, `rim_over_spill`, leaves those rims unknown before this rule
    # sees them: off here, to see this rule alone.)
    results = {}
    for on in (False, True):
        mapper = FloorObstacleMapper(MapperParams(raised_rim_obstacle=on, rim_over_spill=False))
        points, heights = _box_points(0.0)
        for _ in range(10):
            mapper.update(points, heights, np.array([0.0, 0.0, 1.5]))
        results[on] = mapper.fog()
    (types0, _), (types1, heights1) = results[False], results[True]
    assert (types0 == F).sum() > (types1 == F).sum()
    newly = (types0 == F) & (types1 == OB)
    assert newly.any()
    assert np.allclose(heights1[newly], 0.10)
    with pytest.raises(InvalidParameterError, match="raised_rim_obstacle"):
        MapperParams(raised_rim_obstacle=1)


def test_incremental_rims_match_a_whole_grid_recompute():
    # With every FOG rule on (band, shadow, narrow rise: `update_fog_area` rewrites n + 1 = 5
    # cells around the area) a frame that touches only ground a few cells from the box must
    # leave the rims as a recompute of the whole grid gives them: the rim pass covers the
    # whole window the FOG pass rewrote, not the band's 2 cells only; so do the rules after it.
    params = MapperParams(raised_rim_obstacle=True)
    mapper = FloorObstacleMapper(params)
    points, heights = _box_points(0.0)
    for _ in range(10):
        mapper.update(points, heights, np.array([0.0, 0.0, 1.5]))
    # Ground strips 3–5 cells beyond each of the box's sides, one frame each.
    strips = [
        (points[:, 0] > 0.88) & (points[:, 0] < 0.96),
        (points[:, 0] > 0.24) & (points[:, 0] < 0.32),
        (points[:, 1] > 0.38),
        (points[:, 1] < 0.02) & (points[:, 1] > -0.06),
    ]
    for strip in strips:
        for _ in range(3):
            mapper.update(points[strip], heights[strip], np.array([0.0, 0.0, 1.5]))
    types, fog_heights = mapper.fog()
    nx, ny = types.shape
    whole_types = np.full((nx, ny), -1, dtype=np.int8)
    whole_heights = np.full((nx, ny), -1.0)
    obstacle = np.full((nx, ny), np.nan)
    update_fog_area(
        mapper._og, mapper._floor, obstacle, whole_types, whole_heights, params.occ_threshold_level,
        Z0, L, DELTA, 0, nx, 0, ny, mapper._cover_ends, mapper._cover_passes,
        params.floor_pass_min_rays, params.floor_pass_fraction, params.obstacle_margin_cells,
        params.edge_band_m, params.unknown_beside_obstacles, params.narrow_rise_cells,
    )  # fmt: skip
    mark_raised_rims(mapper._floor, obstacle, whole_types, whole_heights, DELTA, 0, nx, 0, ny)
    # The rules after it that fire here: a box's rim beside its uncovered spill.
    assert mark_floor_edges(
        whole_types, whole_heights, mapper._floor, mapper._floor_frame_votes,
        mapper._split_frames, mapper._lower_split_frames, mapper._multi_frames,
        mapper._cover_ends, mapper._cover_passes, params.edge_split_share,
        params.edge_split_lower_share, params.edge_split_contrast, params.edge_foot_min_frames,
        params.edge_band_m, params.uncovered_rims, params.floor_pass_min_rays,
        params.floor_pass_fraction, params.eps_m, params.narrow_rise_cells, 0, nx, 0, ny,
    ) > 0  # fmt: skip
    assert (whole_types == OB).sum() > 0
    assert np.array_equal(types, whole_types)
    known = whole_types != U
    assert np.array_equal(fog_heights[known], whole_heights[known])
