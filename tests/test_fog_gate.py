"""The FOG kernel's structure: the calm-floor gate at the rules' exact thresholds, the cells it
writes, one compiled signature per kernel (`mapper.fog.update_fog_area`).

A floor none of whose neighbours can make a banded rule fire skips the rules (the gate); the
labels must be those of the rules themselves, also where a neighbour lies exactly at a rule's
threshold or one float step beyond it. Grids as in ``test_fog_margin``: with the default grid
(z_min −0.06 m, layers of 0.04 m, δ 0.05 m) the ground (0 m) lies in layer 1 (top 0.02 m), a
surface at 0.02–0.06 m in layer 2 (top 0.06 m): no cell is an obstacle (0.06 ≤ 0 + δ is
false only above 0.07), so only the band's rules act.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mapper import CellType, MapperParams
from mapper.fog import update_fog_area

P = MapperParams()
Z0, L = P.z_min_m, P.layer_m
OCC = 230
F, OB, U = CellType.FLOOR, CellType.OBSTACLE, CellType.UNKNOWN
BAND = 0.02


def grid(heights_m, ny=3):
    """(n, ny) occupancy and floor: column ix a floor at ``heights_m[ix]`` (NaN: nothing)."""
    n = len(heights_m)
    og = np.full((n, ny, P.nz), 128, dtype=np.uint8)
    floor = np.full((n, ny), np.nan)
    for ix, h in enumerate(heights_m):
        if np.isfinite(h):
            og[ix, :, int(np.floor((h - Z0) / L))] = OCC
            floor[ix, :] = h
    return og, floor


def fog(og, floor, area=None, rise=4, shadow=4, island=0):
    """Types and heights with the default band rules over ``area`` (default: all); −1 =
    not written."""
    nx, ny = floor.shape
    ix0, ix1, iy0, iy1 = area or (0, nx, 0, ny)
    types = np.full((nx, ny), -1, dtype=np.int8)
    heights = np.full((nx, ny), -1.0)
    # Eq. 10 everywhere (the kernel recomputes it in the area only): the top of the highest
    # occupied layer.
    occupied = og > P.occ_threshold_level
    k_top = np.where(occupied.any(axis=2), P.nz - 1 - np.argmax(occupied[:, :, ::-1], axis=2), -1)
    obstacle = np.where(k_top >= 0, Z0 + (k_top + 1) * L, np.nan)
    zeros = np.zeros((nx, ny), dtype=np.int32)
    update_fog_area(
        og, floor, obstacle, types, heights, P.occ_threshold_level, Z0, L, P.delta_m,
        ix0, ix1, iy0, iy1, zeros, zeros, P.floor_pass_min_rays, P.floor_pass_fraction,
        0, BAND, True, rise, shadow, island, True, True,
    )  # fmt: skip
    return types, heights


def test_a_sill_one_float_step_above_the_band_makes_both_feet_and_rims_unknown():
    # ground, ground, sill, sill, ground, ground: the sill one float step higher than
    # ground + band. Rim rule: the sill's cells are more than the band above the ground
    # beside them; narrow rise: each ground cell beside the sill is at the foot of a rise
    # two cells deep that drops again. The far ground cells see only ground and sill cells
    # more than the band above them that are no narrow rise's neighbour: floors.
    sill = np.nextafter(BAND, 1.0)
    og, floor = grid([0.0, 0.0, sill, sill, 0.0, 0.0])
    types, heights = fog(og, floor)
    assert types[:, 1].tolist() == [F, U, U, U, U, F]
    assert heights[0, 1] == 0.0 and np.isnan(heights[2, 1])


def test_a_sill_exactly_the_band_above_the_ground_leaves_every_cell_a_floor():
    # The rules compare with ``>``: a rise of exactly the band is no rise.
    og, floor = grid([0.0, 0.0, BAND, BAND, 0.0, 0.0])
    types, heights = fog(og, floor)
    assert types[:, 1].tolist() == [F] * 6
    assert np.array_equal(heights, floor)


def test_a_floor_beside_nothing_stored_is_judged_by_the_rules():
    # ground, raised 0.04, raised 0.04, nothing, ground: the raised cell before the empty
    # cell is the rim before a shadow that ends in a lower floor (the band's shadow rule:
    # the empty cell's threshold is its lowest floor neighbour, the ground, + band); the
    # first raised cell is the rim above the ground. The ground cell at x = 0 is the foot
    # of a rise two cells deep that ends in a cell never seen: unknown too.
    og, floor = grid([0.0, 0.04, 0.04, np.nan, 0.0])
    types, _ = fog(og, floor)
    assert types[:, 1].tolist() == [U, U, U, U, F]


def test_cells_written_are_the_area_and_its_ring():
    # The default rules recompute max(2, narrow rise + 1, shadow + 1) = 5 cells beyond the
    # area (clipped to the grid); nothing beyond is written.
    og, floor = grid([0.0] * 20, ny=20)
    types, _ = fog(og, floor, area=(8, 10, 3, 4))
    written = types >= 0
    expected = np.zeros_like(written)
    expected[3:15, 0:9] = True
    assert np.array_equal(written, expected)
    assert (types[written] == F).all()


@pytest.mark.parametrize("island", [0, 2])
def test_labels_do_not_depend_on_the_area(island):
    # A raised block, a sill and an empty patch on ground: any area's update labels its
    # cells as the whole grid's does (the rules read the maps, never earlier labels).
    heights = np.zeros((24, 16))
    heights[4:9, 3:8] = 0.06
    heights[14:16, :] = 0.04
    heights[18:20, 10:13] = np.nan
    og = np.full((24, 16, P.nz), 128, dtype=np.uint8)
    for (ix, iy), h in np.ndenumerate(heights):
        if np.isfinite(h):
            og[ix, iy, int(np.floor((h - Z0) / L))] = OCC
    whole_types, whole_heights = fog(og, heights, island=island)
    for area in [(0, 3, 0, 3), (5, 9, 2, 6), (12, 20, 8, 16), (20, 24, 0, 16)]:
        types, h = fog(og, heights, area=area, island=island)
        written = types >= 0
        assert np.array_equal(types[written], whole_types[written])
        assert np.array_equal(h[written], whole_heights[written], equal_nan=True)


def test_each_kernel_is_compiled_for_one_signature():
    # A numba literal argument (``1``, ``True``) compiles a kernel once more per value: cold
    # start time. In a fresh process, so that other tests' calls do not count.
    script = (
        "import numba, numpy as np, mapper.fog, tests.test_fog_gate as t\n"
        "og, floor = t.grid([0.0, 0.0, 0.04, 0.04, np.nan, 0.0])\n"
        "t.fog(og, floor); t.fog(og, floor, island=2)\n"
        "for name, value in vars(mapper.fog).items():\n"
        "    if isinstance(value, numba.core.registry.CPUDispatcher):\n"
        "        print(name, len(value.signatures))\n"
    )
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run(
        [sys.executable, "-c", script], cwd=root, capture_output=True, text=True, check=True
    ).stdout
    counts = dict(line.split() for line in out.splitlines())
    # (Kernels loaded from numba's cache count only their top-level signatures; compiled
    # afresh, the inner ones count too.)
    assert int(counts["_fog_rules"]) == 1
    assert all(int(n) <= 1 for n in counts.values()), counts
