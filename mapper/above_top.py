"""Columns holding something above the grid's top: a rise out of the map (beyond the paper).

The occupancy grid ends at its top face (`MapperParams.z_max_m`, 0.58 m by default): a point
above it is no hit (`mapper.occupancy`), and a surface rising out of the grid leaves nothing in
its columns but its foot. A staircase seen from its bottom does that (`eth_stairs`: treads at
0.76 and 0.95 m above a tread at 0.57 m): the riser of the first tread out of the grid stands
where the map only holds the tread below it, whose floor spreads into the riser's cells (the
truth: an obstacle), and the treads above are unknown.

Each column keeps one more 8-bit level, updated by the occupancy's tables once a frame (a hit
wins over a miss, as in `mapper.occupancy`), for "something is right above the grid here":

- **hit**: :data:`MIN_HIT_POINTS` points of the frame lie in the column more than ``delta_m``
  above the grid's top (above the top layer's own surfaces and their noise, as eq. 11 asks of
  an obstacle) and at most ``above_top_reach_m`` above it (a ceiling far overhead is no
  rise), within the sensor's ``max_range_m``;
- **miss**: a ray from a sensor above the grid's top down to a point below it crosses the top
  face inside the column (the space just above the grid was free there).

The FOG (`FloorObstacleMapper.fog`) calls a column whose level passes ``p_occ`` an obstacle
at the grid's top (the lowest height its top can have), whatever eq. 11 made of the cells
below it.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["MIN_HIT_POINTS", "update_above_top"]

_CROSSED = np.int32(1 << 20)
"""`update_above_top`'s flag in a column's scratch count: a ray crossed its top face."""

MIN_HIT_POINTS = 2
"""Points a column needs above the top in one frame for a hit: a riser gives many, while the
stereo matcher's stray mismatches (random depths along rays) put single points above the top
in columns no ray ever clears. `eth_stairs` stereo, seeds 1-8, reach 0.6 m, mean (worst), off
→ 1 / 2 / 4 points: unsafe cells 38.5 (52) → 22.3 (47) / 23.0 (47) / 24.0 (47), floor recall
48.6 → 41.6 / 47.8 / 48.5 % (with 1, 271 ground cells beside the staircase became obstacles
on seed 1), obstacle recall 90.1 → 99.2 / 98.5 / 97.5 %, floor precision 97.3 → 99.4 / 99.3 /
99.2 %."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def update_above_top(
    points,
    sensor_origin,
    origin_x,
    origin_y,
    cell,
    top,
    min_above,
    reach,
    max_range,
    levels,
    counts,
    touched,
    hit_table,
    miss_table,
    min_points,
):
    """One frame's hits and misses (module docstring) applied to the levels, in one pass (numba).

    The same levels as the numpy reference in ``tests/test_above_top.py`` (compared on random
    frames), at +0.06 ms an update on the stage's 6 000 points where that numpy version, with
    its sorts, cost about 1 ms.

    Args:
        points: (N, 3) world points [m].
        sensor_origin: (3,) world sensor position [m].
        origin_x: World x of the grid's corner [m].
        origin_y: World y of the grid's corner [m].
        cell: Cell side [m].
        top: World z of the grid's top face [m].
        min_above: A hit lies more than this above the top [m].
        reach: ... and at most this above it [m].
        max_range: Points farther from the sensor are no hit [m].
        levels: (nx, ny) uint8 levels, updated in place.
        counts: (nx·ny,) int32 scratch, zero on entry and on return: the frame's hits per
            column, with ``_CROSSED`` set where a ray crossed its top face.
        touched: (N,) int64 scratch for the columns the frame touched (a point touches one).
        hit_table: (256,) uint8 table of a hit.
        miss_table: (256,) uint8 table of a miss.
        min_points: Points a column needs for a hit (`MIN_HIT_POINTS`).

    Returns:
        (ix0, ix1, iy0, iy1) the touched columns' bounding box (end-exclusive); ix1 = 0 when
        none.
    """
    nx, ny = levels.shape
    flat = levels.reshape(-1)
    ox, oy, oz = sensor_origin[0], sensor_origin[1], sensor_origin[2]
    n_touched = 0
    for i in range(points.shape[0]):
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(z)):
            continue
        dx, dy, dz = x - ox, y - oy, z - oz
        length = np.sqrt(dx * dx + dy * dy + dz * dz) if max_range < np.inf else 0.0
        height = z - top
        mark = 0
        if height > min_above and height <= reach and length <= max_range:
            fx = np.floor((x - origin_x) / cell)
            fy = np.floor((y - origin_y) / cell)
            mark = 1
        elif oz > top and z < top:
            t = (oz - top) / (oz - z)  # in (0, 1): where the ray crosses the top face
            if max_range == np.inf or t <= min(1.0, max_range / max(length, 1e-12)):
                fx = np.floor((ox + t * dx - origin_x) / cell)
                fy = np.floor((oy + t * dy - origin_y) / cell)
                mark = _CROSSED
        if mark == 0 or not (0.0 <= fx < nx and 0.0 <= fy < ny):
            continue
        c = np.int64(fx) * ny + np.int64(fy)
        if counts[c] == 0:
            touched[n_touched] = c
            n_touched += 1
        counts[c] = counts[c] + 1 if mark == 1 else counts[c] | _CROSSED
    ix0, ix1, iy0, iy1 = nx, 0, ny, 0
    for k in range(n_touched):
        c = touched[k]
        if counts[c] & (_CROSSED - 1) >= min_points:
            flat[c] = hit_table[flat[c]]
        elif counts[c] & _CROSSED:
            flat[c] = miss_table[flat[c]]
        counts[c] = 0
        ix = c // ny
        iy = c - ix * ny
        ix0 = min(ix0, ix)
        ix1 = max(ix1, ix + 1)
        iy0 = min(iy0, iy)
        iy1 = max(iy1, iy + 1)
    return ix0, ix1, iy0, iy1
