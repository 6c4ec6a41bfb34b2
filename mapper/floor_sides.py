"""Side bands of floor regions that lie at another floor's level (beyond Gutmann et al.).

Level regions are grown from row segments (`scanline.levels.grow_floors`): a row is split where its
heights step by more than the step test's standard error allows, and a step the row's noise
hides is not split. A tread's side edge crosses every row of the tread, so each of its rows runs
on over the edge onto the surface beside it, and the tread's region takes those pixels. Through
the stereo head's noise (σ_z about 15 mm a pixel at 1.3 m, correlated errors) the step test
cannot see a 31 mm step at 1.3 m: on the stage's stereo replays (`bench/spill_trace.py`, seeds
1 and 4) the ground cells beside step_1's side edge at y = 0 took 300–420 floor points a run at
the step's height, from ground pixels 2–6 cm past the edge measured at the right depth (median
error −31…−2 mm at 1.3 m, where σ is about 26 mm: not the matcher's window), which step_1's
region had taken (in frame 178 of seed 1 its rows ran 8 and 5–10 columns past its two side
edges at 1.3 m) and `scanline.points.floor_points` had snapped onto its height; the cells held 29 mm
over true ground.

No single row tells such pixels from the tread's own, but the rows together do: the k-th pixel
from the end of each of a region's row runs on one side lies at the same distance from that
side's border in every row, and over the rows a tread's side spans the mean height of the
outermost k strips has a standard error of a few millimetres. :func:`side_strips` scores each
band of 1 … ``max_px`` outermost strips by its distance from the region's level (less the
growing's ``floor_height_tolerance_m``) in standard errors (widened by the noise's
correlation), takes the best-scoring band when it scores above ``grow_sigma_factor``, and moves
it to a floor region it touches whose level it fits by the same test and whose smoothness test
it passes (``floor_max_rms_ratio`` about that level). A band that fits no touching floor — a
matcher's fattened edge between two levels, a box's side face — stays, as before. The region's
level is then taken without the pixels it lost.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _row_runs(labels):
    """(R, 4) int64 every run of one region in a row: row, first column, end column, region.

    Runs of pixels in no region (labels < 0) are left out.
    """
    height, width = labels.shape
    runs = np.empty((height * width, 4), dtype=np.int64)
    count = 0
    for r in range(height):
        c = 0
        while c < width:
            f = labels[r, c]
            start = c
            c += 1
            while c < width and labels[r, c] == f:
                c += 1
            if f >= 0:
                runs[count, 0] = r
                runs[count, 1] = start
                runs[count, 2] = c
                runs[count, 3] = f
                count += 1
    return runs[:count]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _strip_column(start, stop, side, k):
    """Column of strip ``k`` on ``side`` (0 left, 1 right) of the run ``start`` … ``stop − 1``."""
    return start + k if side == 0 else stop - 1 - k


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _strip_sums(runs, z, sigma_z, level, max_px):
    """(F, 2, K) count, sums of ``z − level``, of its square and of ``σ_z²`` of the side strips.

    Strip k of side 0 (1) is the k-th pixel from the left (right) end of each of the region's
    row runs longer than ``2·(k + 1)`` pixels (a band never reaches a run's middle pixel).
    """
    n_regions = level.shape[0]
    n = np.zeros((n_regions, 2, max_px))
    s = np.zeros((n_regions, 2, max_px))
    v = np.zeros((n_regions, 2, max_px))
    q = np.zeros((n_regions, 2, max_px))
    for i in range(runs.shape[0]):
        r, start, stop, f = runs[i, 0], runs[i, 1], runs[i, 2], runs[i, 3]
        if level[f] != level[f]:
            continue
        for side in range(2):
            for k in range(min(max_px, (stop - start - 1) // 2)):
                cc = _strip_column(start, stop, side, k)
                zz = z[r, cc]
                if zz == zz:
                    n[f, side, k] += 1.0
                    s[f, side, k] += zz - level[f]
                    q[f, side, k] += (zz - level[f]) ** 2
                    v[f, side, k] += sigma_z[r, cc] ** 2
    return n, s, q, v


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _best_bands(n, s, q, v, level, sigma_factor, correlation, tol_m):
    """Each region's and side's best-scoring band of strips.

    Returns:
        (F, 2) int64 its width [px] (0: no band scores above ``sigma_factor``) and (F, 2, 6)
        its mean height [m], tolerance [m], pixel count, sum of ``z − level``, sum of its
        square and sum of ``σ_z²``.
    """
    n_regions, _, max_px = n.shape
    width_px = np.zeros((n_regions, 2), dtype=np.int64)
    band = np.zeros((n_regions, 2, 6))
    for f in range(n_regions):
        if level[f] != level[f]:
            continue
        for side in range(2):
            cn = cs = cq = cv = 0.0
            best = sigma_factor
            for k in range(max_px):
                if n[f, side, k] == 0.0:
                    break
                cn += n[f, side, k]
                cs += s[f, side, k]
                cq += q[f, side, k]
                cv += v[f, side, k]
                se = math.sqrt(correlation * cv) / cn
                score = (abs(cs / cn) - tol_m) / se if se > 0.0 else 0.0
                if score > best:
                    best = score
                    width_px[f, side] = k + 1
                    band[f, side, 0] = cs / cn + level[f]
                    band[f, side, 1] = sigma_factor * se + tol_m
                    band[f, side, 2] = cn
                    band[f, side, 3] = cs
                    band[f, side, 4] = cq
                    band[f, side, 5] = cv
    return width_px, band


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def side_strips(labels, z, sigma_z, level, max_px, sigma_factor, correlation, tol_m, max_rms_ratio):
    """Floor labels with the side bands that lie at another floor's level moved to that floor.

    For each floor region and side the band of its ``j`` outermost strips (j = 1 … ``max_px``)
    is tested against the region's level: its mean height's distance from the level less
    ``tol_m``, in standard errors (``sqrt(correlation · Σσ_z²) / n``). The band with the largest
    such score is the candidate when the score exceeds ``sigma_factor``: over a step the score
    grows with every strip of the other surface added and falls with every strip of the
    region's own, so its largest value is at the step. The candidate moves to the floor region
    it touches whose level it fits, by the same test and by the floors' smoothness test (the
    nearest of those); a band that fits no such floor (a matcher's fattened edge, between two
    levels; a box's side face) stays where it is.

    Args:
        labels: (H, W) int64 floor region of each pixel (-1 none, -2 no measurement).
        z: (H, W) the pixels' heights in the frame of ``level`` [m] (NaN: none).
        sigma_z: (H, W) their noise along z [m].
        level: (F,) each region's level [m]; NaN: not a floor (never peeled, never a target).
        max_px: widest band tested on each side [px] (0: none).
        sigma_factor: the score a band needs to leave its region, and to fit another's level.
        correlation: variance inflation of a mean of neighbouring pixels (≥ 1).
        tol_m: height difference a band may have without being another level [m].
        max_rms_ratio: the band's RMS height about the other floor's level is at most this
            multiple of the RMS of its ``σ_z`` (the floors' own smoothness test,
            ``floor_max_rms_ratio``): a box's side face, whose rows lie at many heights, may
            have a mean at a floor's level but is no floor there. 0: no test.

    Returns:
        (H, W) labels with the moved bands; (F, 2) int64 the width of the band each region lost
        on its left and right [px]; (F,) the regions' levels without the pixels they lost [m]
        (every pixel weighted alike: the level less the lost pixels' summed offset over the
        pixels left). Pixel counts are not updated.
    """
    n_regions = level.shape[0]
    depth = np.zeros((n_regions, 2), dtype=np.int64)
    new_level = level.copy()
    if max_px <= 0 or n_regions == 0:
        return labels.copy(), depth, new_level
    height, width = labels.shape
    runs = _row_runs(labels)
    n, s, q, v = _strip_sums(runs, z, sigma_z, level, max_px)
    width_px, band = _best_bands(n, s, q, v, level, sigma_factor, correlation, tol_m)
    # The floors each candidate band touches (4-neighbours outside its region).
    touches = np.zeros((n_regions, 2, n_regions), dtype=np.bool_)
    for i in range(runs.shape[0]):
        r, start, stop, f = runs[i, 0], runs[i, 1], runs[i, 2], runs[i, 3]
        for side in range(2):
            for k in range(min(width_px[f, side], (stop - start - 1) // 2)):
                cc = _strip_column(start, stop, side, k)
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr = r + dr
                    ccc = cc + dc
                    if 0 <= rr < height and 0 <= ccc < width:
                        g = labels[rr, ccc]
                        if g >= 0 and g != f:
                            touches[f, side, g] = True
    # Each band goes to the floor it touches whose level it fits best; none fits: it stays.
    target = np.full((n_regions, 2), -1, dtype=np.int64)
    for f in range(n_regions):
        for side in range(2):
            if width_px[f, side] == 0:
                continue
            mean_m, tol, count, offsets, squares, noise = band[f, side]
            nearest = np.inf
            for g in range(n_regions):
                if not touches[f, side, g] or level[g] != level[g]:
                    continue
                off = abs(mean_m - level[g])
                # Its pixels' mean square about that level, against their noise: level there.
                d = level[g] - level[f]
                square = squares - 2.0 * d * offsets + count * d * d
                level_there = max_rms_ratio <= 0.0 or square <= max_rms_ratio**2 * noise
                if off <= tol and level_there and off < nearest:
                    nearest = off
                    target[f, side] = g
            if target[f, side] >= 0:
                depth[f, side] = width_px[f, side]
    out = labels.copy()
    total = np.zeros(n_regions)
    lost_n = np.zeros(n_regions)
    lost_s = np.zeros(n_regions)
    for i in range(runs.shape[0]):
        r, start, stop, f = runs[i, 0], runs[i, 1], runs[i, 2], runs[i, 3]
        for cc in range(start, stop):
            if z[r, cc] == z[r, cc]:
                total[f] += 1.0
        for side in range(2):
            for k in range(min(depth[f, side], (stop - start - 1) // 2)):
                cc = _strip_column(start, stop, side, k)
                out[r, cc] = target[f, side]
                if z[r, cc] == z[r, cc]:
                    lost_n[f] += 1.0
                    lost_s[f] += z[r, cc] - level[f]
    for f in range(n_regions):
        if lost_n[f] > 0.0 and total[f] > lost_n[f]:
            new_level[f] = level[f] - lost_s[f] / (total[f] - lost_n[f])
    return out, depth, new_level


def peel_side_strips(
    labels: NDArray[np.int64],
    z: NDArray[np.float64],
    sigma_z: NDArray[np.float64],
    level: NDArray[np.float64],
    max_px: int,
    sigma_factor: float,
    correlation: float,
    tol_m: float,
    max_rms_ratio: float,
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """:func:`side_strips` on C-contiguous float64/int64 copies of its inputs (one compile)."""
    return side_strips(
        np.ascontiguousarray(labels, dtype=np.int64),
        np.ascontiguousarray(z, dtype=np.float64),
        np.ascontiguousarray(sigma_z, dtype=np.float64),
        np.ascontiguousarray(level, dtype=np.float64),
        int(max_px),
        float(sigma_factor),
        float(correlation),
        float(tol_m),
        float(max_rms_ratio),
    )
