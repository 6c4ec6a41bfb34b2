"""The measured pixels of a depth image and their depth noise (image frame; depths [m]).

`valid_depth`: the pixels measured within the sensor's range, their depths [m] and inverse
depths [1/m], in one pass.

`local_noise_depth_m`: the noise-adaptive part of scan-line grouping. On a plane the second
difference of inverse depth along a row is pure noise; a clipped box mean of it gives the local
depth noise [m], capped at 1.5× the image's typical noise at the same depth (so a rough surface,
whose bumps look like noise, cannot widen its own tolerances); the typical noise is returned too
(the image's own range profile, `_range_profile`, or a stereo camera's sensor model). Every
tolerance of the row segments, planes and level regions is a multiple of these.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# E[min(|X|, 2.5·E|X|)] = 0.7807·s for X ~ N(0, s²); a second difference has s = sqrt(6)·sigma.
_CLIPPED_MEAN_TO_SIGMA = 1.0 / (0.7807 * math.sqrt(6.0))


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _box_counts(values, half_cols, counts, row_cnt):
    """Values present (not NaN) in every pixel's box of 3 rows × (2·half_cols+1) columns.

    Written to ``counts`` (work space ``row_cnt``): the same for every pass of `_box_mean`,
    whose clipping changes the values summed but not which are present.
    """
    height, width = values.shape
    for r in range(height):
        for c in range(width):
            counts[r, c] = 1.0 if values[r, c] == values[r, c] else 0.0
    _running_row_sums(counts, half_cols, row_cnt)
    _sum_3_rows(row_cnt, counts)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _running_row_sums(values, half_cols, out):
    """``out[r, c] = Σ values[r, c − half_cols … c + half_cols]`` (the part in the image).

    A running sum along each row: the first ``half_cols`` values, then per column the one
    entering added and the one leaving subtracted, in that order. Each row's sum is a chain of
    dependent additions; four rows are summed side by side, each in its own order (written out:
    four scalars the compiler keeps in registers), so that the CPU runs their chains at once
    (session 58: the same sums bit for bit, `tests/test_scanline_fast_paths.py`).
    """
    height, width = values.shape
    lead = min(half_cols, width)
    r = 0
    while r + 4 <= height:
        s0 = s1 = s2 = s3 = 0.0
        for add in range(lead):
            s0 += values[r, add]
            s1 += values[r + 1, add]
            s2 += values[r + 2, add]
            s3 += values[r + 3, add]
        for c in range(width):
            add = c + half_cols
            if add < width:
                s0 += values[r, add]
                s1 += values[r + 1, add]
                s2 += values[r + 2, add]
                s3 += values[r + 3, add]
            drop = c - half_cols - 1
            if drop >= 0:
                s0 -= values[r, drop]
                s1 -= values[r + 1, drop]
                s2 -= values[r + 2, drop]
                s3 -= values[r + 3, drop]
            out[r, c] = s0
            out[r + 1, c] = s1
            out[r + 2, c] = s2
            out[r + 3, c] = s3
        r += 4
    for rr in range(r, height):
        s0 = 0.0
        for add in range(lead):
            s0 += values[rr, add]
        for c in range(width):
            add = c + half_cols
            if add < width:
                s0 += values[rr, add]
            drop = c - half_cols - 1
            if drop >= 0:
                s0 -= values[rr, drop]
            out[rr, c] = s0


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _sum_3_rows(row_values, out):
    """``out[r] = row_values[r − 1] + row_values[r] + row_values[r + 1]`` (rows in the image).

    Added in that order, whole rows at a time (vectorised, no loop over the rows per pixel).
    """
    height, width = row_values.shape
    for r in range(height):
        lo = max(0, r - 1)
        hi = min(height, r + 2)
        for c in range(width):
            out[r, c] = row_values[lo, c]
        for rr in range(lo + 1, hi):
            for c in range(width):
                out[r, c] += row_values[rr, c]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _box_mean(values, clip_factor, clip, half_cols, counts, work, row_sum, out):
    """Mean of min(values, clip_factor·clip) over a 3 × (2·half_cols+1) box.

    NaN = absent; clip_factor 0: no clipping; ``counts``: the values present in each box
    (`_box_counts`). Written to ``out`` (NaN where the box holds fewer than 3 values), which
    may be ``clip`` itself: the clipped values (work space ``work``, 0 where absent: adding 0
    leaves a running sum of non-negative values bit for bit as skipping it does) are all taken
    before ``out`` is written.
    """
    height, width = values.shape
    for r in range(height):
        for c in range(width):
            v = values[r, c]
            if v == v:
                work[r, c] = min(v, clip_factor * clip[r, c]) if clip_factor > 0.0 else v
            else:
                work[r, c] = 0.0
    _running_row_sums(work, half_cols, row_sum)  # over columns [c - half_cols, c + half_cols]
    _sum_3_rows(row_sum, work)
    for r in range(height):
        for c in range(width):
            k = counts[r, c]
            out[r, c] = work[r, c] / k if k >= 3.0 else np.nan


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def local_noise_depth_m(inv_depth, window, min_noise_m, cap_factor, model_inv_sigma):
    """Per-pixel standard deviation of the depth [m], estimated from the data.

    On a plane the second difference of the inverse depth along a row is pure noise
    (std sqrt(6)·sigma_inv). Its absolute value is averaged over a box of 3 rows ×
    (2·window + 1) columns, twice more with the values clipped at 2.5× the previous mean so
    that depth edges in the box barely count.

    A stereo matcher's errors are correlated over its window: second differences of
    neighbours then read them too small. With a sensor model (``model_inv_sigma`` > 0, the
    std of inverse depth, constant for a stereo camera: ``σ_d/(f·b)``) the typical noise is the
    model's ``d²·model_inv_sigma`` and the local estimate never falls below it.

    Args:
        inv_depth: (H, W) inverse depth [1/m], NaN where invalid.
        window: half width [px] of the averaging box along the row.
        min_noise_m: lower bound of the returned noise [m].
        cap_factor: if > 0, cap every estimate at this multiple of the typical noise at the
            same depth (see `_range_profile`).
        model_inv_sigma: std of the inverse depth of the sensor model [1/m]; 0: none, the
            typical noise is the image's own (`_range_profile`).

    Returns:
        (H, W) local depth noise [m] and (H, W) the typical noise at each pixel's depth [m]
        (at least ``min_noise_m``); both NaN where the depth is invalid.
    """
    height, width = inv_depth.shape
    second = np.full((height, width), np.nan)
    for r in range(height):
        for c in range(1, width - 1):
            second[r, c] = abs(inv_depth[r, c - 1] - 2.0 * inv_depth[r, c] + inv_depth[r, c + 1])
    row_sum = np.empty((height, width))
    work = np.empty((height, width))
    counts = np.empty((height, width))
    mean = np.empty((height, width))
    _box_counts(second, window, counts, row_sum)
    _box_mean(second, 0.0, mean, window, counts, work, row_sum, mean)
    for _ in range(2):  # clipped at 2.5× the previous mean
        _box_mean(second, 2.5, mean, window, counts, work, row_sum, mean)
    # Pixels whose box had too few samples: the image-wide mean of the box means.
    fallback = 0.0
    n_finite = 0
    for r in range(height):
        for c in range(width):
            if mean[r, c] == mean[r, c]:
                fallback += mean[r, c]
                n_finite += 1
    fallback = fallback / n_finite if n_finite > 0 else 0.0
    out = np.full((height, width), np.nan)
    for r in range(height):
        for c in range(width):
            z = inv_depth[r, c]
            if not z > 0.0:
                continue
            m = mean[r, c]
            if m != m:  # NaN
                m = fallback
            out[r, c] = max(m * _CLIPPED_MEAN_TO_SIGMA / (z * z), min_noise_m)
    if model_inv_sigma > 0.0:
        typical = np.full((height, width), np.nan)
        for r in range(height):
            for c in range(width):
                z = inv_depth[r, c]
                if z > 0.0:
                    typical[r, c] = max(model_inv_sigma / (z * z), min_noise_m)
                    out[r, c] = max(out[r, c], typical[r, c])
    else:
        typical = _range_profile(out, inv_depth, min_noise_m)
    if cap_factor > 0.0:
        for r in range(height):
            for c in range(width):
                if out[r, c] == out[r, c]:
                    out[r, c] = max(min(out[r, c], cap_factor * typical[r, c]), min_noise_m)
    return out, typical


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _range_profile(sigma, inv_depth, min_noise_m):
    """The image's typical depth noise at each pixel's depth [m] (NaN where invalid).

    The typical noise is a robust (twice clipped) mean of the local estimates ``sigma`` in 16
    depth bins, interpolated linearly in depth; bins with fewer than 20 pixels take their
    neighbour's level, and with no usable bin at all the local estimate itself is returned. A
    rough surface raises its own local estimate (its bumps look like noise at the pixel scale);
    this profile is what the sensor shows elsewhere at that range.
    """
    height, width = sigma.shape
    typical = sigma.copy()
    n_bins = 16
    d_min = np.inf
    d_max = 0.0
    for r in range(height):
        for c in range(width):
            z = inv_depth[r, c]
            if z > 0.0:
                d_min = min(d_min, 1.0 / z)
                d_max = max(d_max, 1.0 / z)
    if not d_max > d_min:
        return typical
    step = (d_max - d_min) / n_bins
    bins = np.full((height, width), -1, np.int64)  # each pixel's bin, found once (-1: none)
    for r in range(height):
        for c in range(width):
            z = inv_depth[r, c]
            if z > 0.0:
                bins[r, c] = min(int((1.0 / z - d_min) / step), n_bins - 1)
    level = np.full(n_bins, np.inf)
    for _ in range(3):
        total = np.zeros(n_bins)
        count = np.zeros(n_bins)
        for r in range(height):
            for c in range(width):
                b = bins[r, c]
                if b >= 0:
                    total[b] += min(sigma[r, c], 2.0 * level[b])
                    count[b] += 1.0
        for b in range(n_bins):
            level[b] = total[b] / count[b] if count[b] >= 20.0 else np.inf
    for r in range(height):
        for c in range(width):
            z = inv_depth[r, c]
            if not z > 0.0:
                continue
            pos = (1.0 / z - d_min) / step - 0.5
            b0 = min(max(math.floor(pos), 0), n_bins - 1)
            b1 = min(b0 + 1, n_bins - 1)
            t = min(max(pos - b0, 0.0), 1.0)
            lo = level[b0]
            hi = level[b1]
            if lo == np.inf and hi == np.inf:
                continue
            if lo == np.inf:
                level_here = hi
            elif hi == np.inf:
                level_here = lo
            else:
                level_here = (1.0 - t) * lo + t * hi
            typical[r, c] = max(level_here, min_noise_m)
    return typical


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def valid_depth(depth, min_depth_m, max_depth_m):
    """The measured pixels of a depth image, in one pass.

    Args:
        depth: (H, W) depth [m] (NaN: none).
        min_depth_m: depths below this are no measurement [m].
        max_depth_m: depths above this are no measurement [m].

    Returns:
        (H, W) bool valid (within [min, max], NaN not), (H, W) depth with NaN where not valid,
        (H, W) its inverse [1/m] (NaN there), (N,) the valid pixels' flat indices, ascending.
    """
    height, width = depth.shape
    valid = np.empty((height, width), dtype=np.bool_)
    masked = np.empty((height, width))
    inverse = np.empty((height, width))
    index = np.empty(height * width, dtype=np.int64)
    n = 0
    for r in range(height):
        for c in range(width):
            d = depth[r, c]
            ok = d >= min_depth_m and d <= max_depth_m
            valid[r, c] = ok
            if ok:
                masked[r, c] = d
                index[n] = r * width + c
                n += 1
            else:
                masked[r, c] = np.nan
            inverse[r, c] = 1.0 / masked[r, c]
    return valid, masked, inverse, index[:n].copy()
