"""Floor verification (eq. 8) and floor update (eq. 9) on hand-made grids."""

import numpy as np
import pytest

from mapper import MapperParams
from mapper.floor_map import update_floor, verify_floor

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


def run_update(floor, og, cols, heights):
    ny = og.shape[1]
    point_cell = np.array([ix * ny + iy for ix, iy in cols], dtype=np.int64)
    return update_floor(
        floor,
        og,
        point_cell,
        np.asarray(heights, dtype=float),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
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
        og,
        point_cell,
        np.array([0.1, 0.1, np.nan]),
        P.occ_threshold_level,
        Z0,
        L,
        P.eps_m,
        P.nu,
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
