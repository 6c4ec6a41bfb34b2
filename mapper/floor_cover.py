"""Whether a stored floor covers its cell (beyond the paper): rays that reach it must end on it.

A floor height stored in a cell (eq. 9) says the whole 4 cm square lies on that surface. Two
kinds of cells break this and the paper's map cannot tell: a cell beside a step edge whose own
surface is hidden behind the step takes the step's height from the points that registration
error and the segmentation's snapping carry over the edge, and a cell holding a riser inside it
takes the height of whichever surface got most votes. Eq. 8 checks a floor against free space
only per 40 mm layer, and the surface's own hits keep that layer occupied.

The check here is at the floor's own height: every ray of a frame is followed down to each
floor height ``h`` the frame holds. A ray that ends as a floor point within ``±eps_m`` of its
cell's stored floor *ends* on it; a ray that crosses the plane ``z = h`` inside a cell whose
stored floor is within ``±eps_m`` of ``h`` and ends more than ``eps_m`` below ``h`` *passes*
through it. A surface covering the cell stops every ray that reaches its height there; a band
of spilled points along one side of a cell is passed by the rays that reach the rest of the
cell's square at that height. Per cell the counts are kept since the floor was stored (they
restart when the stored height moves more than ``eps_m`` from the height they were started
at: another surface took the cell). The FOG (`mapper.fog`) treats a floor passed by more than
`MapperParams.floor_pass_fraction` of the rays reaching it as no floor: the cell is then
unknown, or an obstacle where eq. 11 finds one above the floor.

The counts use the frame's own rays and points, so a misregistered frame (a wrong camera pose)
is consistent with itself: the check finds spill and slivers, not pose errors.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from mapper.occupancy import floor_int


def frame_floor_heights(floor_heights: NDArray[np.float64], eps: float) -> NDArray[np.float64]:
    """The distinct floor heights of a frame [m], ascending, none within ``eps`` of the last kept.

    A ray crossing two planes of one frame within ``eps`` of each other (two fragments of one
    surface) must count once for the cell whose floor both match.
    """
    return _kept_heights(np.ascontiguousarray(floor_heights, dtype=np.float64), float(eps))


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _kept_heights(floor_heights: NDArray[np.float64], eps: float) -> NDArray[np.float64]:
    """`frame_floor_heights` compiled: one pass into a small sorted set, then the ``eps`` merge.

    A frame's floor heights come in runs (a plane's points are consecutive in the image), so
    only a new run's value is looked up in the set of distinct values seen so far (ascending,
    some tens of values), and inserted where it belongs if it is not there yet. This is
    ``np.unique`` of the finite values, written out: numba's ``np.unique`` compiles its sorts
    (3.3 s of a cold start's compile CPU, `bench/bench_cold.py kernels`) for a set that the
    insertion keeps sorted at a fraction of that (a frame's numpy sort and unique cost 0.04 ms,
    ~5 % of an update, a reason to compile this at all).
    """
    distinct = np.empty(floor_heights.shape[0])
    n = 0
    last = np.nan
    for h in floor_heights:
        if not np.isfinite(h) or h == last:
            continue
        last = h
        k = n  # where h belongs: after every smaller value
        while k > 0 and distinct[k - 1] > h:
            k -= 1
        if k > 0 and distinct[k - 1] == h:
            continue  # seen in an earlier run
        for j in range(n, k, -1):
            distinct[j] = distinct[j - 1]
        distinct[k] = h
        n += 1
    kept = np.empty(n)
    k = 0
    for i in range(n):
        if k == 0 or distinct[i] > kept[k - 1] + eps:
            kept[k] = distinct[i]
            k += 1
    return kept[:k]


@numba.njit(cache=True, inline="always")
def _counts_for(f: float, ref: float, ends: int, passes: int, eps: float):
    """A cell's (reference height, ends, passes) for its stored floor ``f``, restarted if new.

    Restarted at ``f`` when ``f`` lies more than ``eps`` from the reference (another surface,
    or none before: a NaN reference).

    Scalars in and out: an inlined helper taking the count arrays costs reference counting per
    call (measured: 0.06 of the kernel's 0.10 ms a stage frame).
    """
    if abs(f - ref) <= eps:
        return ref, ends, passes
    return f, 0, 0


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def accumulate_cover(
    floor: NDArray[np.float64],
    cover_ref: NDArray[np.float64],
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    point_cell: NDArray[np.int64],
    points: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    sensor_origin: NDArray[np.float64],
    plane_heights: NDArray[np.float64],
    origin_x: float,
    origin_y: float,
    cell: float,
    eps: float,
) -> None:
    """Count one frame's rays ending on and passing through the stored floors (module doc).

    Called after eq. 9 (`mapper.floor_map.update_floor`), so a ray counts against the floor it
    left in its cell.

    Args:
        floor: (nx, ny) stored floor heights [m], NaN = invalid.
        cover_ref: (nx, ny) the floor height the counts were started at [m], NaN = none;
            updated in place.
        cover_ends: (nx, ny) rays that ended on the stored floor; updated in place.
        cover_passes: (nx, ny) rays that passed through it; updated in place.
        point_cell: (N,) column index ``ix*ny + iy`` of each point, negative if dropped (its
            ray is not followed).
        points: (N, 3) world points [m].
        floor_heights: (N,) height of each point's plane [m]; non-finite = not floor.
        sensor_origin: (3,) camera centre in the world [m].
        plane_heights: (K,) the frame's distinct floor heights [m] (`frame_floor_heights`).
        origin_x: World x of the grid's corner [m].
        origin_y: World y of the grid's corner [m].
        cell: Cell side [m].
        eps: Gate of eq. 9 [m].
    """
    nx, ny = floor.shape
    floor_flat = floor.reshape(-1)
    ref = cover_ref.reshape(-1)
    ends = cover_ends.reshape(-1)
    passes = cover_passes.reshape(-1)
    ox, oy, oz = sensor_origin[0], sensor_origin[1], sensor_origin[2]
    for i in range(point_cell.shape[0]):
        col = point_cell[i]
        if col < 0:
            continue
        h = floor_heights[i]
        f = floor_flat[col]
        if np.isfinite(h) and abs(h - f) <= eps:  # NaN floor: never
            ref[col], ends[col], passes[col] = _counts_for(f, ref[col], ends[col], passes[col], eps)
            ends[col] += 1
        pz = points[i, 2]
        for k in range(plane_heights.shape[0]):
            hk = plane_heights[k]
            if not (pz < hk - eps and hk < oz):
                continue
            t = (oz - hk) / (oz - pz)
            ix = floor_int((ox + t * (points[i, 0] - ox) - origin_x) / cell)
            iy = floor_int((oy + t * (points[i, 1] - oy) - origin_y) / cell)
            if ix < 0 or ix >= nx or iy < 0 or iy >= ny:
                continue
            crossed = ix * ny + iy
            f = floor_flat[crossed]
            if abs(hk - f) <= eps:
                ref[crossed], ends[crossed], passes[crossed] = _counts_for(
                    f, ref[crossed], ends[crossed], passes[crossed], eps
                )
                passes[crossed] += 1
