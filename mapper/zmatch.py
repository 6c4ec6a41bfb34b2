"""z-shift matching of new floor points against the floor map (paper Fig. 2 and Sec. IV).

The matched pairs are the floor points (finite ``h``) whose column has a valid floor height,
with residuals ``r_i = Floor(x_i, y_i) − h_i``. Gating keeps outliers out: the residuals are
centred on their median and only pairs within ``eps_m`` of it (the same surface, eq. 9's gate)
are kept. Points on a surface the map does not hold yet (a new box) or on a wrongly segmented
plane thus drop out.

The shift is the least-squares one over the kept pairs: their mean (computed in numba with
numpy's pairwise summation, bit for bit). Their median was tried: over the stage replays of seeds
1–8 it moves the rows but not the error (mean |error| 1.04 → 1.07 mm, the worst row 2.19 →
2.41 mm), so the paper's estimator stays.

Beyond the paper (``zmatch_nearest_level``): the median picks the level most pairs lie on, and
when that is a surface the map holds at a wrong height (merged into the ground when seen from
far, or mapped with a wrong tilt) a frame that sees mostly it is shifted onto it, and its true
heights never outvote the wrong ones. The robot's elevation is already corrected, so the shift
expected is 0: when the median's level lies more than ``2·eps_m`` from 0 (a whole surface level
away from "no shift") and the residuals hold a level within ``eps_m`` of 0 (a flat ±``eps_m``
mean shift from 0 stops on it) with at least ``zmatch_min_pairs`` pairs and at least
``zmatch_nearest_min_share`` of the pairs the median's level holds — the frame's data agree with
the map there as they are — that level's pairs are kept instead. (A thinner level near 0 is far
pairs of mixed surfaces that happen to agree, in a frame off by a whole step: the stereo
zig-zag's sill.) A frame whose residuals
form one level (however far from 0) is matched as before.

What the caller does with the result (the paper's rule, see `frame_decision`): apply the shift
when it is accepted (enough pairs, plausible size); otherwise keep the frame unshifted only if
segmentation found the ground plane; with few matches and no ground plane, withdraw the frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.errors import InvalidInputError
from mapper.grid import GridGeometry
from mapper.pairwise import pairwise_sum
from mapper.params import MapperParams
from mapper.validation import real_array, real_scalar


@dataclass(frozen=True)
class ZMatch:
    """Result of matching one frame's floor points to the floor map.

    Attributes:
        shift_m: z shift to add to the points' z and h [m] (0 when nothing matched).
        pairs: Matched pairs kept after gating.
        rms_m: RMS of the kept residuals after the shift [m] (NaN when no pairs).
        accepted: ``pairs >= zmatch_min_pairs`` and ``|shift_m| <= zmatch_max_shift_m``.
    """

    shift_m: float
    pairs: int
    rms_m: float
    accepted: bool


class ZDecision(IntEnum):
    """What to do with a frame after z matching."""

    APPLY_SHIFT = 0
    KEEP_UNSHIFTED = 1
    WITHDRAW = 2


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _residuals(points, heights, floor_map, origin_x, origin_y, cell):
    """``Floor − h`` of the matched pairs, in point order (numba).

    A pair is a point with finite ``h`` whose (x, y) falls in a cell of ``floor_map`` (the
    convention of `GridGeometry.cell_of`: ``ix = floor((x - origin_x) / cell)``) and whose
    residual is finite (the column has a valid floor height).
    """
    nx, ny = floor_map.shape
    out = np.empty(points.shape[0])
    n = 0
    for i in range(points.shape[0]):
        gx = np.floor((points[i, 0] - origin_x) / cell)
        gy = np.floor((points[i, 1] - origin_y) / cell)
        if not (gx >= 0 and gx < nx and gy >= 0 and gy < ny and np.isfinite(heights[i])):
            continue  # NaN and ±inf fail the range tests
        residual = floor_map[int(gx), int(gy)] - heights[i]
        if np.isfinite(residual):
            out[n] = residual
            n += 1
    return out[:n]


def match_z(
    points_world: NDArray[np.float64],
    floor_heights: NDArray[np.float64],
    floor_map: NDArray[np.float64],
    geometry: GridGeometry,
    params: MapperParams,
) -> ZMatch:
    """The gated z shift of floor points onto ``floor_map`` (nx, ny) [m, NaN = invalid].

    Compiled (numba) throughout; the result is bit for bit that of the plain numpy formulation
    (``np.median`` for the gate; means with numpy's pairwise summation).
    """
    h = real_array(floor_heights, "floor_heights")
    points = real_array(points_world, "points_world")
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise InvalidInputError(
            f"points_world must have shape (N, 3) or (N, 2), got {points.shape}"
        )
    if h.shape != (points.shape[0],):
        raise InvalidInputError(
            f"floor_heights must have shape ({points.shape[0]},) like the points, got {h.shape}"
        )
    origin_x, origin_y = geometry.origin_xy_m
    residual = _residuals(
        points, h, real_array(floor_map, "floor_map"), origin_x, origin_y, geometry.cell_m
    )
    return shift_from_residuals(residual, params)


_MAX_LEVEL_STEPS = 64
"""Most window moves of `_level_from` (a flat-window mean shift stops after a few)."""


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _median(values):
    """``np.median`` of a non-empty float64 array (NaN if one is NaN, as numpy's).

    Wirth's selection of the middle value(s) in a copy: numba's own ``np.median`` compiles
    about four times longer, and its NaN handling is not numpy's (it gives 2.5 for
    ``[NaN, 1, 2, 3]``). Which of 0.0 and -0.0 it returns may differ from numpy's; the gate
    cannot tell them apart.
    """
    work = values.copy()
    n = work.size
    for i in range(n):
        if work[i] != work[i]:
            return np.nan
    half = n // 2
    upper = _select(work, half)
    if n % 2 == 1:
        return upper
    lower = work[0]  # work[:half] now holds the half smallest values
    for i in range(1, half):
        lower = max(lower, work[i])
    return (lower + upper) / 2


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _select(work, k):
    """The k-th smallest of ``work`` (no NaN), moved to ``work[k]`` with the smaller before it.

    Wirth's algorithm: Hoare partitions around the middle element of the shrinking range.
    """
    lo = 0
    hi = work.size - 1
    while lo < hi:
        pivot = work[(lo + hi) // 2]
        i = lo
        j = hi
        while i <= j:
            while work[i] < pivot:
                i += 1
            while pivot < work[j]:
                j -= 1
            if i <= j:
                swapped = work[i]
                work[i] = work[j]
                work[j] = swapped
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return work[k]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _level_from(residual_m, start_m, eps_m):
    """The residuals' level reached from ``start_m``: (centre [m], residuals within ±eps of it).

    Mean shift with a flat ±``eps_m`` window: the window's centre moves to the mean of the
    residuals inside it until that set no longer changes (at most `_MAX_LEVEL_STEPS` moves), so
    it stops on the level (a run of residuals no wider than the window's reach) nearest
    ``start_m``. (start_m, 0) when the first window holds none.
    """
    centre = start_m
    count = 0
    for _ in range(_MAX_LEVEL_STEPS):
        total = 0.0
        inside = 0
        for value in residual_m:
            if abs(value - centre) <= eps_m:
                total += value
                inside += 1
        if inside == 0:
            return centre, 0
        moved = total / inside
        if inside == count and moved == centre:
            break
        centre = moved
        count = inside
    return centre, count


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _gated_shift(residual_m, eps_m, nearest_level, min_pairs, min_share):
    """(shift, pairs kept, rms) of the residuals ``Floor − h`` [m] (numba); see the module.

    With ``nearest_level``, when the median's level lies more than ``2·eps_m`` from 0 (no
    window of ±``eps_m`` about 0 reaches it: another surface level than "no shift") and the
    level reached from 0 (`_level_from`) lies within ``eps_m`` of 0 and holds at least
    ``min_pairs`` residuals and at least ``min_share`` times as many as the median's level,
    that level's residuals are kept instead.
    """
    if residual_m.size == 0:
        return 0.0, 0, np.nan
    centre = _median(residual_m)
    kept = residual_m[np.abs(residual_m - centre) <= eps_m]
    if kept.size == 0:  # an even count whose two middle residuals are more than 2·eps apart
        return 0.0, 0, np.nan
    shift = pairwise_sum(kept) / kept.size
    if nearest_level and abs(shift) > 2.0 * eps_m:
        level, count = _level_from(residual_m, 0.0, eps_m)
        if count >= min_pairs and count >= min_share * kept.size and abs(level) <= eps_m:
            kept = residual_m[np.abs(residual_m - level) <= eps_m]
            shift = pairwise_sum(kept) / kept.size
    squares = (kept - shift) ** 2
    return shift, kept.size, np.sqrt(pairwise_sum(squares) / kept.size)


def shift_from_residuals(residual_m: NDArray[np.float64], params: MapperParams) -> ZMatch:
    """The gated shift of the matched pairs' residuals ``Floor − h`` [m] (compiled)."""
    residual = real_array(residual_m, "residual_m")
    if residual.ndim != 1:
        raise InvalidInputError(f"residual_m must be one-dimensional, got shape {residual.shape}")
    shift, pairs, rms = _gated_shift(
        np.ascontiguousarray(residual),
        float(params.eps_m),
        bool(params.zmatch_nearest_level),
        int(params.zmatch_min_pairs),
        float(params.zmatch_nearest_min_share),
    )
    accepted = pairs >= params.zmatch_min_pairs and abs(shift) <= params.zmatch_max_shift_m
    return ZMatch(float(shift), int(pairs), float(rms), bool(accepted))


def frame_decision(match: ZMatch, ground_plane_found: bool) -> ZDecision:
    """The paper's rule: shift if the match is trusted; else keep only with a ground plane."""
    if match.accepted:
        return ZDecision.APPLY_SHIFT
    return ZDecision.KEEP_UNSHIFTED if ground_plane_found else ZDecision.WITHDRAW


def apply_z_shift(
    points_world: ArrayLike, floor_heights: ArrayLike, shift_m: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Copies of the points and floor heights with ``shift_m`` added to z and h (NaN stays)."""
    real_scalar(shift_m, "shift_m")
    p = real_array(points_world, "points_world").copy()
    p[:, 2] += shift_m
    return p, real_array(floor_heights, "floor_heights") + shift_m
