"""z-shift matching of new floor points against the floor map (paper Fig. 2 and Sec. IV).

The shift ``s`` minimises ``Σ (Floor(x_i, y_i) − (h_i + s))²`` over the matched pairs: floor
points (finite ``h``) whose column has a valid floor height. Gating keeps outliers from
dominating: the residuals ``r_i = Floor − h_i`` are first centred on their median and only pairs
within ``eps_m`` of it (the same surface, eq. 9's gate) are kept; the least-squares shift over
them is their mean. Points on a surface the map does not hold yet (a new box) or on a wrongly
segmented plane thus drop out.

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


@numba.njit(cache=True)
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
    """Least-squares z shift of floor points onto ``floor_map`` (nx, ny) [m, NaN = invalid].

    The pairs are gathered by a numba kernel; the median, gate and means stay numpy's (its
    pairwise summation), so the result is bit for bit that of the plain numpy formulation.
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


def shift_from_residuals(residual_m: NDArray[np.float64], params: MapperParams) -> ZMatch:
    """The gated least-squares shift of the matched pairs' residuals ``Floor − h`` [m]."""
    if residual_m.size == 0:
        return ZMatch(0.0, 0, float("nan"), False)
    centre = float(np.median(residual_m))
    kept = residual_m[np.abs(residual_m - centre) <= params.eps_m]
    if kept.size == 0:  # an even count whose two middle residuals are more than 2·eps apart
        return ZMatch(0.0, 0, float("nan"), False)
    shift = float(np.mean(kept))
    rms = float(np.sqrt(np.mean((kept - shift) ** 2)))
    accepted = kept.size >= params.zmatch_min_pairs and abs(shift) <= params.zmatch_max_shift_m
    return ZMatch(shift, int(kept.size), rms, bool(accepted))


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
