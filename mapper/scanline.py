"""Numba kernels of scan-line grouping (after Jiang & Bunke) on a depth image.

Everything here works in the image: a plane ``n·p = h`` seen by a pinhole camera has an inverse
depth that is affine in the normalised pixel coordinates, ``1/d = A·x + B·y + C`` with
``(A, B, C) = n/h`` (camera frame), and a straight 3D line on it has ``1/d = a + b·x`` along an
image row. Fitting these linear models by least squares puts the error where a depth camera
has it (along the viewing ray), so fitted planes are not tilted towards the rays as a 3D
total-least-squares fit of ray-smeared points is; every tolerance is a depth difference [m].

1. `local_noise_depth_m`: noise-adaptive part. On a plane the second difference of inverse
   depth along a row is pure noise; a clipped box mean of it gives the local depth noise,
   capped at 1.5× the image's typical noise at the same depth (so a rough surface, whose bumps
   look like noise, cannot widen its own tolerances); the typical noise is returned too.
2. `split_rows`: every row is cut into runs of valid pixels and each run recursively split
   until a weighted line fits every pixel within ``split_factor·sigma + floor``, its RMS
   residual is within ``rms_factor·sigma`` and no depth step shows in its residuals (mean
   residuals in windows either side of a pixel boundary differ by at most ``edge_factor``
   standard errors). Splits go to the step, else the outlier, else the residuals' CUSUM peak.
   `propagate_breaks` then splits, at a lower threshold, where the rows above or below break.
3. `segment_sums` / `grow_planes`: seeds are three overlapping segments in adjacent rows that
   fit one plane, taken best-fitting first; planes grow breadth-first into touching segments
   (rows above, below, same row) whose end points and RMS fit the current plane within
   tolerances made of the segment's noise and the plane's prediction uncertainty; the plane
   is refit (from per-segment moment sums) after every accepted segment.
4. `reassign_segments`: segments move to a touching plane that fits them clearly better.
5. `fill_pixels`: leftover pixels next to a plane (or a level floor) join it if they lie on it
   within tolerance.
6. `plane_fits`, `plane_moments`, `segment_labels`: per-plane parameters and geometry.

The kernels compile with numba's ``error_model="numpy"``: no branch before every division to
raise ZeroDivisionError (a float division by zero gives inf or NaN, as in numpy); the same
results otherwise, bit for bit, and 5-20 % faster. Helpers take arrays with a row index, not a
row's view: a view made per call (an array struct and its reference count) cost more than the
arithmetic of the per-segment and per-pixel helpers.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# E[min(|X|, 2.5·E|X|)] = 0.7807·s for X ~ N(0, s²); a second difference has s = sqrt(6)·sigma.
_CLIPPED_MEAN_TO_SIGMA = 1.0 / (0.7807 * math.sqrt(6.0))
_N_SUMS = 10  # n, sx, sy, sxx, sxy, syy, sz, sxz, syz, szz (z = inverse depth)

# Constant arguments of kernels called with both a constant and a variable are numpy scalars:
# numba compiles a kernel once per argument type, and a literal (0, True) is a type of its own.
_NO_GAP = np.int64(0)  # `_overlap`'s gap between segments of adjacent rows (must overlap)
_GROWING = np.bool_(True)  # `_segment_misfit` of a growing plane (its uncertainty counts)
_SEED_TEST = np.bool_(False)  # `_segment_misfit` of a seed's own plane (segment noise only)
_INVERSE_DEPTH_MODEL = np.bool_(True)  # `fill_pixels` of the planes (inverse depth)
_LEVEL_MODEL = np.bool_(False)  # `fill_pixels` of the level regions (heights)

#: How far [sigma] inside the sensor's range limit a pixel's predicted inverse depth must lie for
#: `plane_refits` to count it: a pixel that far inside is lost to the cut with probability 0.13 %,
#: which moves the mean of those kept by 0.004 sigma.
RANGE_MARGIN_SIGMAS = 3.0


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _box_counts(values, half_cols, counts, row_cnt):
    """Values present (not NaN) in every pixel's box of 3 rows × (2·half_cols+1) columns.

    Written to ``counts`` (work space ``row_cnt``): the same for every pass of `_box_mean`,
    whose clipping changes the values summed but not which are present.
    """
    height, width = values.shape
    for r in range(height):
        k = 0.0
        for add in range(min(half_cols, width)):
            k += 1.0 if values[r, add] == values[r, add] else 0.0
        for c in range(width):
            add = c + half_cols
            if add < width:
                k += 1.0 if values[r, add] == values[r, add] else 0.0
            drop = c - half_cols - 1
            if drop >= 0:
                k -= 1.0 if values[r, drop] == values[r, drop] else 0.0
            row_cnt[r, c] = k
    _sum_3_rows(row_cnt, counts)


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
    for r in range(height):
        # Running sums over columns [c - half_cols, c + half_cols].
        s = 0.0
        for add in range(min(half_cols, width)):
            s += work[r, add]
        for c in range(width):
            add = c + half_cols
            if add < width:
                s += work[r, add]
            drop = c - half_cols - 1
            if drop >= 0:
                s -= work[r, drop]
            row_sum[r, c] = s
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
def _line_from_sums(w, wx, wxx, wz, wxz, wzz):
    """Weighted least squares ``z = p + q·x`` from sums; returns (p, q, weighted RSS)."""
    det = w * wxx - wx * wx
    if det <= 1e-12 * w * wxx:
        p = wz / w
        return p, 0.0, max(wzz - p * wz, 0.0)
    q = (w * wxz - wx * wz) / det
    p = (wz - q * wx) / w
    return p, q, max(wzz - p * wz - q * wxz, 0.0)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _depth_gap(inv_a, inv_b):
    """|1/inv_a − 1/inv_b| [m] for inverse depths."""
    return abs(inv_a - inv_b) / (inv_a * inv_b)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _step_scales(edge_window, correlation):
    """``sqrt(correlation·(1/kl + 1/kr))`` for window sizes kl, kr in 0..edge_window.

    The standard error (in sigma units) of the difference of two windows' mean residuals,
    looked up per pixel boundary instead of computed there (the same values).
    """
    scales = np.full((edge_window + 1, edge_window + 1), np.inf)
    for kl in range(1, edge_window + 1):
        for kr in range(1, edge_window + 1):
            scales[kl, kr] = math.sqrt(correlation * (1.0 / kl + 1.0 / kr))
    return scales


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def split_rows(
    inv_depth,
    x,
    sigma,
    split_factor,
    rms_factor,
    edge_window,
    edge_factor,
    tolerance_floor_m,
    min_pixels,
    correlation,
):
    """Split every image row into straight segments.

    Args:
        inv_depth: (H, W) inverse depth [1/m], NaN where invalid.
        x: (W,) normalised image x of the columns, (u − cx)/fx.
        sigma: (H, W) depth noise [m].
        split_factor: a pixel deviating more than this many sigma (+ floor) splits its piece.
        rms_factor: a piece whose weighted RMS residual exceeds this many sigma is split.
        edge_window: pixels on each side of a boundary for the step statistic.
        edge_factor: a piece with a step statistic above this (in sigma units) is split there.
        tolerance_floor_m: constant added to every tolerance [m].
        min_pixels: shorter pieces are not segments (their pixels stay unassigned).
        correlation: variance inflation of a mean of neighbouring pixels by correlated noise
            (1: white); the step statistic's standard error grows by its square root.

    Returns:
        rows, starts, stops (stop exclusive) int64 arrays sorted by row then column, and a
        (S, 3) float table: line offset p, slope q (``1/d = p + q·x``), mean sigma [m].
    """
    height, width = inv_depth.shape
    cap = height * (width // max(min_pixels, 1) + 1)
    rows = np.empty(cap, np.int64)
    starts = np.empty(cap, np.int64)
    stops = np.empty(cap, np.int64)
    table = np.empty((cap, 3))
    count = 0
    stack = np.empty((width + 2, 2), np.int64)
    pre = np.zeros((width + 1, 6))
    res_pre = np.zeros(width + 1)
    step_scales = _step_scales(edge_window, correlation)
    # Per pixel of the row, whatever piece it is in: the weighted terms of the line fit, the
    # outlier tolerance and the residual's scale (computed once a row, not at every piece a
    # pixel is in as the row is split: the same values, a third of the divisions).
    terms = np.empty((width, 6))
    split_tol = np.empty(width)
    res_scale = np.empty(width)
    # Per piece, each pixel's outlier ratio and residual and each boundary's step statistic
    # are computed in loops of their own (no branches: vectorised divisions) before the
    # serial maxima and sums, which keep their order.
    ratios = np.empty(width)
    residuals = np.empty(width)
    steps = np.empty(width + 1)
    window_f = float(edge_window)
    interior_scale = step_scales[edge_window, edge_window]
    for r in range(height):
        inv_row = inv_depth[r]
        for k in range(width):
            z = inv_row[k]
            wk = 1.0 / (z * z * sigma[r, k]) ** 2
            terms[k, 0] = wk
            terms[k, 1] = wk * x[k]
            terms[k, 2] = wk * x[k] * x[k]
            terms[k, 3] = wk * z
            terms[k, 4] = wk * x[k] * z
            terms[k, 5] = wk * z * z
            split_tol[k] = split_factor * sigma[r, k] + tolerance_floor_m
            res_scale[k] = z * z * sigma[r, k] + tolerance_floor_m * z * z
        c = 0
        while c < width:
            if not inv_row[c] > 0.0:
                c += 1
                continue
            run_start = c
            while c < width and inv_row[c] > 0.0:
                c += 1
            stack[0, 0] = run_start
            stack[0, 1] = c
            top = 1
            while top > 0:  # depth first, left piece on top: segments come out left to right
                top -= 1
                a = stack[top, 0]
                b = stack[top, 1]
                if b - a < min_pixels:
                    continue
                # Prefix sums of the weighted line fit (weights 1/sigma² of inverse depth).
                for k in range(a, b):
                    i = k - a + 1
                    pre[i, 0] = pre[i - 1, 0] + terms[k, 0]
                    pre[i, 1] = pre[i - 1, 1] + terms[k, 1]
                    pre[i, 2] = pre[i - 1, 2] + terms[k, 2]
                    pre[i, 3] = pre[i - 1, 3] + terms[k, 3]
                    pre[i, 4] = pre[i - 1, 4] + terms[k, 4]
                    pre[i, 5] = pre[i - 1, 5] + terms[k, 5]
                n = b - a
                p, q, rss = _line_from_sums(
                    pre[n, 0], pre[n, 1], pre[n, 2], pre[n, 3], pre[n, 4], pre[n, 5]
                )
                for k in range(a, b):
                    z = inv_row[k]
                    line = p + q * x[k]
                    ratios[k] = abs(z - line) / (z * line) / split_tol[k]  # `_depth_gap`
                    residuals[k] = (z - line) / res_scale[k]
                worst = 0.0
                worst_at = a
                s_sum = 0.0
                for k in range(a, b):
                    s_sum += sigma[r, k]
                    if ratios[k] > worst:
                        worst = ratios[k]
                        worst_at = k
                # Weighted RMS in sigma units, with the floor tolerance as extra allowance.
                chi = math.sqrt(rss / max(n - 2, 1))
                sigma_mean = s_sum / n
                chi_limit = rms_factor * (1.0 + tolerance_floor_m / sigma_mean)
                # Step statistic: difference of mean normalised residuals in windows left and
                # right of each pixel boundary (a depth step the line fit half absorbed).
                res_pre[0] = 0.0
                for k in range(a, b):
                    res_pre[k - a + 1] = res_pre[k - a] + residuals[k]
                edge = 0.0
                edge_at = a
                if edge_window >= 2:  # else no window holds 2 pixels: no step statistic
                    # Boundary m lies between pixels a+m-1 and a+m; m in [2, n-2] (windows of
                    # at least 2 pixels), full windows from m = edge_window to n - edge_window.
                    for m in range(2, n - 1):
                        if edge_window <= m <= n - edge_window:
                            continue
                        kl = min(edge_window, m)
                        kr = min(edge_window, n - m)
                        mean_l = (res_pre[m] - res_pre[m - kl]) / kl
                        mean_r = (res_pre[m + kr] - res_pre[m]) / kr
                        steps[m] = abs(mean_r - mean_l) / step_scales[kl, kr]
                    for m in range(edge_window, n - edge_window + 1):
                        mean_l = (res_pre[m] - res_pre[m - edge_window]) / window_f
                        mean_r = (res_pre[m + edge_window] - res_pre[m]) / window_f
                        steps[m] = abs(mean_r - mean_l) / interior_scale
                    for m in range(2, n - 1):
                        if steps[m] > edge:
                            edge = steps[m]
                            edge_at = a + m
                if worst <= 1.0 and edge <= edge_factor and (n <= 3 or chi <= chi_limit):
                    rows[count] = r
                    starts[count] = a
                    stops[count] = b
                    table[count, 0] = p
                    table[count, 1] = q
                    table[count, 2] = sigma_mean
                    count += 1
                    continue
                if edge > edge_factor:
                    split = edge_at
                elif worst > 1.0 and chi <= chi_limit:
                    split = worst_at if worst_at > a else a + 1  # cut off one outlying pixel
                else:
                    # The CUSUM peak of the residuals: at a step edge for steps, else it cuts
                    # off a straight part.
                    split = a + n // 2
                    best = -1.0
                    for m in range(1, n):
                        if abs(res_pre[m]) > best:
                            best = abs(res_pre[m])
                            split = a + m
                split = min(max(split, a + 1), b - 1)
                stack[top, 0] = split
                stack[top, 1] = b
                stack[top + 1, 0] = a
                stack[top + 1, 1] = split
                top += 2
    return rows[:count].copy(), starts[:count].copy(), stops[:count].copy(), table[:count].copy()


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _weighted_line(inv_row, x, sigma_row, a, b):
    """Weighted line ``1/d = p + q·x`` over columns a:b and the mean sigma [m]."""
    w = wx = wxx = wz = wxz = wzz = 0.0
    s = 0.0
    for k in range(a, b):
        z = inv_row[k]
        wk = 1.0 / (z * z * sigma_row[k]) ** 2
        w += wk
        wx += wk * x[k]
        wxx += wk * x[k] * x[k]
        wz += wk * z
        wxz += wk * x[k] * z
        wzz += wk * z * z
        s += sigma_row[k]
    p, q, _ = _line_from_sums(w, wx, wxx, wz, wxz, wzz)
    return p, q, s / (b - a)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def propagate_breaks(
    inv_depth,
    x,
    sigma,
    rows,
    starts,
    stops,
    table,
    check_rows,
    edge_window,
    edge_factor,
    tolerance_floor_m,
    min_pixels,
    reach,
    correlation,
):
    """Split segments where the rows above or below break, if a (weaker) step shows there.

    A depth edge running across rows (e.g. the side of a low step) breaks most rows; in a noisy
    row its step statistic may stay under the threshold of `split_rows`. Knowing where the
    neighbouring rows break, a step statistic above ``edge_factor`` within ``reach`` columns
    of one of those breaks (edges run diagonally in the image) is enough to split
    (``correlation`` as in `split_rows`).

    Only the segments of the rows in ``check_rows`` ((H,) bool) are tested; the others are
    kept as they are. A segment's test depends only on itself and the breaks of the rows
    next to it, so after a round, a row needs testing again only if it or a row next to it
    split (`plane_labels` passes these rows: the same segments as testing every row).

    Returns:
        New arrays in the format of `split_rows`, and (H,) bool: the rows that split.
    """
    height, width = inv_depth.shape
    n = rows.shape[0]
    split_rows_out = np.zeros(height, np.bool_)
    # near_break[r, c]: row r breaks within `reach` columns of boundary c.
    near_break = np.zeros((height, width + 1), np.bool_)
    for i in range(n):
        for boundary in (starts[i], stops[i]):
            for cc in range(max(boundary - reach, 0), min(boundary + reach + 1, width + 1)):
                near_break[rows[i], cc] = True
    cap = 2 * n + 1
    out_rows = np.empty(cap, np.int64)
    out_starts = np.empty(cap, np.int64)
    out_stops = np.empty(cap, np.int64)
    out_table = np.empty((cap, 3))
    count = 0
    res_pre = np.zeros(width + 1)
    step_scales = _step_scales(edge_window, correlation)
    for i in range(n):
        r = rows[i]
        a = starts[i]
        b = stops[i]
        length = b - a
        best = 0.0
        split = -1
        if length >= 2 * min_pixels and check_rows[r]:
            p = table[i, 0]
            q = table[i, 1]
            inv_row = inv_depth[r]
            for k in range(a, b):
                z = inv_row[k]
                res_pre[k - a + 1] = res_pre[k - a] + (z - (p + q * x[k])) / (
                    z * z * (sigma[r, k] + tolerance_floor_m)
                )
            for m in range(min_pixels, length - min_pixels + 1):
                c = a + m
                above = r > 0 and near_break[r - 1, c]
                below = r + 1 < height and near_break[r + 1, c]
                if not (above or below):
                    continue
                kl = min(edge_window, m)
                kr = min(edge_window, length - m)
                mean_l = (res_pre[m] - res_pre[m - kl]) / kl
                mean_r = (res_pre[m + kr] - res_pre[m]) / kr
                t = abs(mean_r - mean_l) / step_scales[kl, kr]
                if t > best:
                    best = t
                    split = c
        if split > 0 and best > edge_factor:
            split_rows_out[r] = True
            for lo, hi in ((a, split), (split, b)):
                pp, qq, ss = _weighted_line(inv_depth[r], x, sigma[r], lo, hi)
                out_rows[count] = r
                out_starts[count] = lo
                out_stops[count] = hi
                out_table[count, 0] = pp
                out_table[count, 1] = qq
                out_table[count, 2] = ss
                count += 1
        else:
            out_rows[count] = r
            out_starts[count] = a
            out_stops[count] = b
            out_table[count, 0] = table[i, 0]
            out_table[count, 1] = table[i, 1]
            out_table[count, 2] = table[i, 2]
            count += 1
    return (
        out_rows[:count].copy(),
        out_starts[:count].copy(),
        out_stops[:count].copy(),
        out_table[:count].copy(),
        split_rows_out,
    )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _accumulate_run(sums, p, inv_depth, x, yv, r, c, labels, keep, width):
    """Add a run's pixel moments to ``sums[p, :10]``; returns the column after the run.

    The run: the pixels labelled ``p`` from column c of row r on, those with ``keep[r, c]``
    counted. Summed in registers, starting from and going back to the plane's sums: the same
    additions in the same order as pixel by pixel into the array, without a store and a reload
    per sum and pixel. Inlined in numba IR: a call per run would take and drop a reference to
    each array argument (atomic NRT operations).
    """
    s0, s1, s2, s3, s4 = sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3], sums[p, 4]
    s5, s6, s7, s8, s9 = sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9]
    while c < width and labels[r, c] == p:
        if keep[r, c]:
            xv = x[c]
            z = inv_depth[r, c]
            s0 += 1.0
            s1 += xv
            s2 += yv
            s3 += xv * xv
            s4 += xv * yv
            s5 += yv * yv
            s6 += z
            s7 += xv * z
            s8 += yv * z
            s9 += z * z
        c += 1
    sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3], sums[p, 4] = s0, s1, s2, s3, s4
    sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9] = s5, s6, s7, s8, s9
    return c


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _solve_plane(sums, out):
    """Inverse-depth plane from sums: out = [A, B, C, s², inv(M) as 9 values]; False if singular.

    s² is the residual variance of the inverse depth [1/m²].
    """
    n = sums[0]
    m00 = sums[3]
    m01 = sums[4]
    m02 = sums[1]
    m11 = sums[5]
    m12 = sums[2]
    m22 = n
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    det = m00 * c00 + m01 * c01 + m02 * c02
    scale = m00 * m11 * m22
    if n < 3.0 or not det > 1e-12 * scale:
        return False
    c11 = m00 * m22 - m02 * m02
    c12 = m01 * m02 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    i00 = c00 / det
    i01 = c01 / det
    i02 = c02 / det
    i11 = c11 / det
    i12 = c12 / det
    i22 = c22 / det
    v0 = sums[7]
    v1 = sums[8]
    v2 = sums[6]
    a = i00 * v0 + i01 * v1 + i02 * v2
    b = i01 * v0 + i11 * v1 + i12 * v2
    c = i02 * v0 + i12 * v1 + i22 * v2
    rss = sums[9] - (a * v0 + b * v1 + c * v2)
    out[0] = a
    out[1] = b
    out[2] = c
    out[3] = max(rss, 0.0) / max(n - 3.0, 1.0)
    out[4] = i00
    out[5] = i01
    out[6] = i02
    out[7] = i01
    out[8] = i11
    out[9] = i12
    out[10] = i02
    out[11] = i12
    out[12] = i22
    return True


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _predict_sigma_depth(plane, x, yv, inv_pred):
    """Standard deviation [m] of the plane's predicted depth at (x, y)."""
    g0 = x
    g1 = yv
    quad = (
        g0 * (plane[4] * g0 + plane[5] * g1 + plane[6])
        + g1 * (plane[7] * g0 + plane[8] * g1 + plane[9])
        + (plane[10] * g0 + plane[11] * g1 + plane[12])
    )
    return math.sqrt(max(plane[3] * quad, 0.0)) / (inv_pred * inv_pred)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _residual_square_sum(plane, sums, i, o):
    """Σ (z − A·x − B·y − C)² from moment sums ``sums[i, o:o + 10]`` (a segment's, weighted).

    Row and offset, not a slice: a view per call costs more than this sum.
    """
    pa = plane[0]
    pb = plane[1]
    pc = plane[2]
    total = (
        sums[i, o + 9]
        - 2.0 * (pa * sums[i, o + 7] + pb * sums[i, o + 8] + pc * sums[i, o + 6])
        + pa * pa * sums[i, o + 3]
        + pb * pb * sums[i, o + 5]
        + pc * pc * sums[i, o + 0]
        + 2.0 * (pa * pb * sums[i, o + 4] + pa * pc * sums[i, o + 1] + pb * pc * sums[i, o + 2])
    )
    return max(total, 0.0)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _segment_rms(plane, seg_sums, i):
    """RMS depth residual [m] of segment i against a plane, from its sums (see `segment_sums`).

    Uses the depth-weighted sums: (Δ inverse depth)·d² is the depth residual to first order.
    """
    return math.sqrt(_residual_square_sum(plane, seg_sums, i, _N_SUMS) / seg_sums[i, 0])


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _segment_misfit(
    plane, seg_sums, seg_table, i, x, yv, a, b, grow_factor, rms_factor, tol0, use_pred, limit
):
    """How badly segment i (columns a:b of the row at image y = yv) fits a plane.

    Returns the largest ratio of deviation to tolerance over the two end points of the
    segment's line and its RMS residual (≤ 1: fits; inf: plane behind the camera). With
    ``use_pred`` the plane's own prediction uncertainty widens the tolerances (growing);
    without, only the segment's noise counts (testing a seed against the plane fit to it).
    As soon as a part's ratio exceeds ``limit`` that ratio is returned without the rest (the
    answer is then only known to exceed ``limit``; inf: every part).

    Inlined into its callers in numba IR (``inline="always"``, as `_segment_fits`): called for
    every segment tested, a call of its own took and dropped a reference to each array
    argument (atomic NRT increments and decrements, 5 % of a frame's segmentation).
    """
    n = b - a
    sigma_seg = seg_table[i, 2]
    worst = 0.0
    for k in (a, b - 1):
        inv_plane = plane[0] * x[k] + plane[1] * yv + plane[2]
        if not inv_plane > 0.0:
            return np.inf
        inv_seg = seg_table[i, 0] + seg_table[i, 1] * x[k]
        sigma_pred = _predict_sigma_depth(plane, x[k], yv, inv_plane) if use_pred else 0.0
        tol = grow_factor * math.sqrt(4.0 * sigma_seg * sigma_seg / n + sigma_pred**2) + tol0
        worst = max(worst, _depth_gap(inv_seg, inv_plane) / tol)
        if worst > limit:
            return worst
    mid = (a + b - 1) // 2
    inv_mid = plane[0] * x[mid] + plane[1] * yv + plane[2]
    sigma_pred = _predict_sigma_depth(plane, x[mid], yv, inv_mid) if use_pred else 0.0
    rms_limit = rms_factor * math.sqrt(sigma_seg * sigma_seg + sigma_pred * sigma_pred) + tol0
    return max(worst, _segment_rms(plane, seg_sums, i) / rms_limit)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy", inline="always")
def _segment_fits(plane, seg_sums, seg_table, i, x, yv, a, b, grow_factor, rms_factor, tol0):
    """Whether segment i lies on a growing plane (see `_segment_misfit`; inlined likewise)."""
    return (
        _segment_misfit(
            plane,
            seg_sums,
            seg_table,
            i,
            x,
            yv,
            a,
            b,
            grow_factor,
            rms_factor,
            tol0,
            _GROWING,
            1.0,
        )
        <= 1.0
    )


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _add_segment(sums, seg_sums, i):
    """Add segment i's moment sums (``seg_sums[i, :10]``) to ``sums``."""
    for k in range(_N_SUMS):
        sums[k] += seg_sums[i, k]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def segment_sums(inv_depth, x, y, seg_rows, seg_starts, seg_stops):
    """(S, 20) moment sums of every segment for the inverse-depth plane model.

    Columns 0-9: n, Σx, Σy, Σx², Σxy, Σy², Σz, Σxz, Σyz, Σz² (z = inverse depth); columns
    10-19: the same weighted by depth⁴, so that weighted inverse-depth residuals are depth
    residuals to first order.
    """
    n_seg = seg_rows.shape[0]
    out = np.empty((n_seg, 2 * _N_SUMS))
    for i in range(n_seg):
        r = seg_rows[i]
        yv = y[r]
        # Summed in registers from 0 in pixel order (the same sums as adding into the row).
        n = sx = sy = sxx = sxy = syy = sz = sxz = syz = szz = 0.0
        w0 = wx = wy = wxx = wxy = wyy = wz = wxz = wyz = wzz = 0.0
        for c in range(seg_starts[i], seg_stops[i]):
            z = inv_depth[r, c]
            xv = x[c]
            n += 1.0
            sx += xv
            sy += yv
            sxx += xv * xv
            sxy += xv * yv
            syy += yv * yv
            sz += z
            sxz += xv * z
            syz += yv * z
            szz += z * z
            w = 1.0 / (z * z * z * z)
            w0 += w
            wx += w * xv
            wy += w * yv
            wxx += w * xv * xv
            wxy += w * xv * yv
            wyy += w * yv * yv
            wz += w * z
            wxz += w * xv * z
            wyz += w * yv * z
            wzz += w * z * z
        for k, value in enumerate(
            (
                n,
                sx,
                sy,
                sxx,
                sxy,
                syy,
                sz,
                sxz,
                syz,
                szz,
                w0,
                wx,
                wy,
                wxx,
                wxy,
                wyy,
                wz,
                wxz,
                wyz,
                wzz,
            )
        ):
            out[i, k] = value
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _overlap(a0, a1, b0, b1, gap):
    return a0 < b1 + gap and b0 < a1 + gap


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _row_index(seg_rows, height):
    """row_first (H+1,): segments of row r are row_first[r]:row_first[r+1]."""
    n_seg = seg_rows.shape[0]
    row_first = np.full(height + 1, n_seg, np.int64)
    for i in range(n_seg - 1, -1, -1):
        row_first[seg_rows[i]] = i
    for r in range(height - 1, -1, -1):
        if row_first[r] > row_first[r + 1]:
            row_first[r] = row_first[r + 1]
    return row_first


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _stable_order(values):
    """``np.argsort(values, kind="mergesort")``, bit for bit, compiled in a fraction of the time.

    Indices sorting ``values`` ascending, ties in index order, NaN last (numba's and numpy's
    order): a plain bottom-up merge sort.
    """
    n = values.shape[0]
    order = np.empty(n, np.int64)
    for i in range(n):
        order[i] = i
    merged = np.empty(n, np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i = lo
            j = mid
            for k in range(lo, hi):
                # The right run's head goes first only if strictly before (stable).
                if j < hi and (i >= mid or _before(values[order[j]], values[order[i]])):
                    merged[k] = order[j]
                    j += 1
                else:
                    merged[k] = order[i]
                    i += 1
        order, merged = merged, order
        width *= 2
    return order


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _before(a, b):
    """``a`` sorts strictly before ``b``: smaller, or a number against NaN (NaN last)."""
    return a < b or (b != b and a == a)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _best_seed(s, segments, plane_of, limits, work):
    """Best seed triple containing segment s among free segments.

    Tries rows (r, r+1, r+2), (r-1, r, r+1), (r-2, r-1, r), in each picking row by row away
    from s the longest free segment overlapping the previous one. Writes the best triple to
    ``members`` and returns its misfit (≤ 1: valid seed; inf: none).

    Every segment picked beside s is written to ``tried[s]`` ((S, 9) int64, -1 for none;
    entry ``3·i + k`` for row k of the i-th triple tried): while s and these stay free the
    result cannot change (a pick is the longest free overlapping segment, and taking others
    only removes candidates that lost to it, or that a broken triple never had), so
    `grow_planes` can reuse it instead of scoring again.

    Args:
        s: The segment.
        segments: ``(seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first)``,
            as `grow_planes` has them (``row_first``: `_row_index`).
        plane_of: (S,) plane of every segment so far (-1: free).
        limits: ``(grow_factor, rms_factor, tol0, seed_min_pixels)`` of `grow_planes`.
        work: ``(members, sums, plane, chosen, tried)``: (3,) the best triple (written),
            (`_N_SUMS`,) and (13,) scratch for the fit, (3,) scratch for a triple, (S, 9)
            the segments picked beside each seed (row s written).
    """
    seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first = segments
    grow_factor, rms_factor, tol0, seed_min_pixels = limits
    members, sums, plane, chosen, tried = work
    for k in range(9):
        tried[s, k] = -1
    height = row_first.shape[0] - 1
    lengths_s = seg_stops[s] - seg_starts[s]
    best_score = np.inf
    if lengths_s < seed_min_pixels:
        return best_score
    r = seg_rows[s]
    for offset in (0, -1, -2):
        if r + offset < 0 or r + offset + 2 >= height:
            continue
        for k in range(3):  # element-wise: a slice is a view, made at every call
            chosen[k] = -1
        chosen[-offset] = s
        ok = True
        for direction in (1, -1):
            k = -offset + direction
            while 0 <= k <= 2:
                prev = chosen[k - direction]
                pick = -1
                pick_len = 0
                rr = r + offset + k
                for t in range(row_first[rr], row_first[rr + 1]):
                    length = seg_stops[t] - seg_starts[t]
                    if plane_of[t] >= 0 or length < seed_min_pixels or length <= pick_len:
                        continue
                    if _overlap(
                        seg_starts[prev], seg_stops[prev], seg_starts[t], seg_stops[t], _NO_GAP
                    ):
                        pick = t
                        pick_len = length
                if pick < 0:
                    ok = False
                    break
                chosen[k] = pick
                tried[s, -3 * offset + k] = pick
                k += direction
            if not ok:
                break
        if not ok:
            continue
        for k in range(_N_SUMS):
            sums[k] = 0.0
        for k in range(3):
            _add_segment(sums, seg_sums, chosen[k])
        if not _solve_plane(sums, plane):
            continue
        # A triple only counts if it fits (misfit ≤ 1) and beats the best so far (strictly):
        # its members' misfits stop at the first above that.
        limit = min(best_score, 1.0)
        score = 0.0
        for k in range(3):
            t = chosen[k]
            score = max(
                score,
                _segment_misfit(
                    plane,
                    seg_sums,
                    seg_table,
                    t,
                    x,
                    y[seg_rows[t]],
                    seg_starts[t],
                    seg_stops[t],
                    grow_factor,
                    rms_factor,
                    tol0,
                    _SEED_TEST,
                    limit,
                ),
            )
            if score > limit:
                break
        if score < best_score and score <= 1.0:
            best_score = score
            for k in range(3):  # element-wise: a slice copy compiles a shape check (~1.5 s)
                members[k] = chosen[k]
    return best_score


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def grow_planes(
    inv_depth,
    x,
    y,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_table,
    seg_sums,
    grow_factor,
    rms_factor,
    tolerance_floor_m,
    seed_min_pixels,
):
    """Region growing of planes over row segments.

    Every segment's best seed triple is scored first (misfit to the plane through it, see
    `_segment_misfit`); planes are then seeded best-first, so seeds in the interior of surfaces
    win over seeds straddling an edge (e.g. tread, tread, riser of a low step), and grow
    breadth-first into touching segments that fit the current plane, refit after each one.

    Args:
        inv_depth: (H, W) inverse depth [1/m].
        x: (W,) normalised image x of the columns.
        y: (H,) normalised image y of the rows.
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        seg_table: (S, 3) line parameters and mean sigma of each segment.
        seg_sums: (S, 20) moment sums of each segment (`segment_sums`).
        grow_factor: end points must agree within this many sigma.
        rms_factor: the RMS depth residual must be within this many sigma.
        tolerance_floor_m: constant added to every tolerance [m].
        seed_min_pixels: minimum length of each seed segment.

    Returns:
        (S,) int64 plane index of every segment, -1 for none; planes numbered in creation order.
    """
    height = inv_depth.shape[0]
    n_seg = seg_rows.shape[0]
    plane_of = np.full(n_seg, -1, np.int64)
    if n_seg == 0:
        return plane_of
    row_first = _row_index(seg_rows, height)
    sums = np.zeros(_N_SUMS)
    plane = np.zeros(13)
    members = np.full(3, -1, np.int64)
    chosen = np.full(3, -1, np.int64)  # `_best_seed`'s work space
    tried = np.full((n_seg, 9), -1, np.int64)
    seed_members = np.full((n_seg, 3), -1, np.int64)
    scores = np.full(n_seg, np.inf)
    segments = (seg_sums, x, y, seg_rows, seg_starts, seg_stops, seg_table, row_first)
    limits = (grow_factor, rms_factor, tolerance_floor_m, seed_min_pixels)
    work = (members, sums, plane, chosen, tried)
    for s in range(n_seg):
        scores[s] = _best_seed(s, segments, plane_of, limits, work)
        for k in range(3):
            seed_members[s, k] = members[k]
    order = _stable_order(scores)
    queue = np.empty(n_seg, np.int64)
    n_planes = 0
    for s in order:
        if scores[s] > 1.0:
            break
        if plane_of[s] >= 0:
            continue
        # Scored again only if a plane took one of the segments its triples picked.
        stale = False
        for k in range(9):
            t = tried[s, k]
            if t >= 0 and plane_of[t] >= 0:
                stale = True
                break
        if not stale:
            score = scores[s]
            for k in range(3):
                members[k] = seed_members[s, k]
        else:
            score = _best_seed(s, segments, plane_of, limits, work)
        if score > 1.0:
            continue
        label = n_planes
        n_planes += 1
        head = 0
        tail = 0
        for k in range(_N_SUMS):
            sums[k] = 0.0
        for k in range(3):
            t = members[k]
            plane_of[t] = label
            queue[tail] = t
            tail += 1
            _add_segment(sums, seg_sums, t)
        _solve_plane(sums, plane)
        while head < tail:
            q = queue[head]
            head += 1
            rq = seg_rows[q]
            for rr in (rq - 1, rq, rq + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == rq else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    if plane_of[t] >= 0:
                        continue
                    if not _overlap(seg_starts[q], seg_stops[q], seg_starts[t], seg_stops[t], gap):
                        continue
                    if _segment_fits(
                        plane,
                        seg_sums,
                        seg_table,
                        t,
                        x,
                        y[rr],
                        seg_starts[t],
                        seg_stops[t],
                        grow_factor,
                        rms_factor,
                        tolerance_floor_m,
                    ):
                        plane_of[t] = label
                        queue[tail] = t
                        tail += 1
                        _add_segment(sums, seg_sums, t)
                        _solve_plane(sums, plane)
    return plane_of


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_fits(inv_depth, x, y, labels, n_planes):
    """Inverse-depth plane (A, B, C) per label ``1/d = A·x + B·y + C`` and pixel counts.

    Returns:
        (P, 13) plane table (A, B, C, residual variance [1/m²], inverse normal matrix) and
        (P,) int64 pixel counts. Degenerate planes have NaN parameters.
    """
    height, width = labels.shape
    sums = np.zeros((n_planes, _N_SUMS))
    keep = labels >= 0
    for r in range(height):
        c = 0
        while c < width:
            p = labels[r, c]
            if p >= 0:
                c = _accumulate_run(sums, p, inv_depth, x, y[r], r, c, labels, keep, width)
            else:
                c += 1
    planes = np.full((n_planes, 13), np.nan)
    counts = np.zeros(n_planes, np.int64)
    for p in range(n_planes):
        counts[p] = int(sums[p, 0])
        _solve_plane(sums[p], planes[p])
    return planes, counts


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_refits(inv_depth, x, y, labels, planes, factor, min_noise_m, min_inv_depth):
    """Refit each plane of `plane_fits` on its pixels clear of outliers and of the range limit.

    ``sigma`` of a pixel of plane ``p``: ``max(s_p, min_noise_m/d²)`` in inverse depth, ``s_p``
    the first fit's RMS residual (``planes[p, 3]`` is its square), the floor the depth-noise
    floor at its depth d (exact data has ``s_p ≈ 0``). A pixel counts if

    - its residual is at most ``factor·sigma`` (``factor`` 0: no outlier test): a few
      outlier pixels (a stereo matcher's edge fattening) no longer pull the normal;
    - its inverse depth predicted by the first fit lies ``RANGE_MARGIN_SIGMAS·sigma`` above
      ``min_inv_depth`` (1/the sensor's range limit; 0: none). A sensor cuts at its range on
      the *measured* depth, so near the limit only the pixels measured too near are there:
      the plane's far side reads near and its normal leans back (synthetic ground, 0.85 m,
      30° down, the stage's depth-mode errors, 4 m cut: the tilt 0.18 mrad off, camera height
      0.2 mm; without the cut 0.02 mrad). Whether a pixel that far inside was measured does
      not depend on its noise, so the pixels kept are unbiased.

    The labels and counts stay; only the parameters change. A plane whose pixels left are
    degenerate keeps its first fit; one that lost none gets it back bit for bit (same sums
    in the same order).

    Returns:
        (P, 13) plane table as `plane_fits`'s, refitted.
    """
    height, width = labels.shape
    n_planes = planes.shape[0]
    sums = np.zeros((n_planes, _N_SUMS))
    # The pixels counted, then their sums run by run (`_accumulate_run`).
    counted = np.zeros((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            p = labels[r, c]
            if p < 0 or math.isnan(planes[p, 0]):
                continue
            z = inv_depth[r, c]
            predicted = planes[p, 0] * x[c] + planes[p, 1] * y[r] + planes[p, 2]
            s_p = math.sqrt(planes[p, 3])
            floor = min_noise_m * predicted * predicted
            if predicted - RANGE_MARGIN_SIGMAS * max(s_p, floor) < min_inv_depth:
                continue
            if factor > 0.0 and abs(z - predicted) > factor * max(s_p, min_noise_m * z * z):
                continue
            counted[r, c] = True
    for r in range(height):
        c = 0
        while c < width:
            p = labels[r, c]
            if p >= 0:
                c = _accumulate_run(sums, p, inv_depth, x, y[r], r, c, labels, counted, width)
            else:
                c += 1
    refits = planes.copy()
    for p in range(n_planes):
        if not _solve_plane(sums[p], refits[p]):
            for k in range(planes.shape[1]):  # element-wise, as in plane_moments
                refits[p, k] = planes[p, k]
        # The residual variance stays the first fit's: the trimmed one underestimates the noise.
        refits[p, 3] = planes[p, 3]
    return refits


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def fill_pixels(values, x, y, labels, sigma, model, factor, tolerance_floor_m, passes, inverse):
    """Let unassigned pixels join a 4-neighbour's label if they lie on it within tolerance.

    Label ``p`` predicts ``model[p, 0]·x + model[p, 1]·y + model[p, 2]`` at a pixel. With
    ``inverse`` the values and predictions are inverse depths (the planes of `plane_fits`) and
    the gap is their depth difference; otherwise they are heights (the level floors: model
    ``(0, 0, h)``) and the gap is the height difference. A pixel joins the best-fitting
    neighbour within ``factor·sigma + tolerance_floor_m``. Each pass looks only at the labels
    of the previous pass, so a label spreads by at most ``passes`` pixels. ``labels`` (H, W)
    int64 (-1 = none, -2 = invalid) is updated in place.
    """
    height, width = labels.shape
    for _ in range(passes):
        before = labels.copy()
        for r in range(height):
            for c in range(width):
                if before[r, c] != -1:
                    continue
                best = -1
                best_gap = 1e30
                tol = factor * sigma[r, c] + tolerance_floor_m
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr = r + dr
                    cc = c + dc
                    if rr < 0 or rr >= height or cc < 0 or cc >= width:
                        continue
                    p = before[rr, cc]
                    if p < 0:
                        continue
                    predicted = model[p, 0] * x[c] + model[p, 1] * y[r] + model[p, 2]
                    if inverse:
                        if not predicted > 0.0:
                            continue
                        gap = _depth_gap(values[r, c], predicted)
                    else:
                        gap = abs(values[r, c] - predicted)
                    if gap <= tol and gap < best_gap:
                        best = p
                        best_gap = gap
                if best >= 0:
                    labels[r, c] = best


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def reassign_segments(
    inv_depth,
    x,
    y,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_table,
    seg_sums,
    plane_of,
    grow_factor,
    rms_factor,
    tolerance_floor_m,
    passes,
):
    """Move segments to a neighbouring plane that fits them clearly better, then refit.

    Region growing is greedy: a plane grown early (e.g. a tilted one seeded across a step
    edge) may hold segments that belong to a neighbour grown later. Each pass compares every
    assigned segment with the planes of the segments touching it (rows above, below, same
    row) and moves it when another plane accepts it and its RMS residual there is below
    0.8× the current one. ``plane_of`` is updated in place.

    Returns:
        How many segments moved in total.
    """
    height = inv_depth.shape[0]
    n_seg = seg_rows.shape[0]
    n_planes = 0
    for i in range(n_seg):
        n_planes = max(n_planes, plane_of[i] + 1)
    if n_planes == 0:
        return 0
    row_first = _row_index(seg_rows, height)
    moved_total = 0
    sums = np.zeros((n_planes, _N_SUMS))
    planes = np.full((n_planes, 13), np.nan)
    valid = np.zeros(n_planes, np.bool_)
    for _ in range(passes):
        sums[:] = 0.0
        for i in range(n_seg):
            if plane_of[i] >= 0:
                r = seg_rows[i]
                _add_segment(sums[plane_of[i]], seg_sums, i)
        for p in range(n_planes):
            valid[p] = _solve_plane(sums[p], planes[p])
        before = plane_of.copy()
        moved = 0
        for i in range(n_seg):
            own = before[i]
            if own < 0 or not valid[own]:
                continue
            r = seg_rows[i]
            a = seg_starts[i]
            b = seg_stops[i]
            best_rms = 0.8 * _segment_rms(planes[own], seg_sums, i)
            best = own
            for rr in (r - 1, r, r + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == r else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    q = before[t]
                    if q < 0 or q in (own, best) or not valid[q]:
                        continue
                    if not _overlap(a, b, seg_starts[t], seg_stops[t], gap):
                        continue
                    rms_q = _segment_rms(planes[q], seg_sums, i)
                    if rms_q < best_rms and _segment_fits(
                        planes[q],
                        seg_sums,
                        seg_table,
                        i,
                        x,
                        y[r],
                        a,
                        b,
                        grow_factor,
                        rms_factor,
                        tolerance_floor_m,
                    ):
                        best = q
                        best_rms = rms_q
            if best != own:
                plane_of[i] = best
                moved += 1
        moved_total += moved
        if moved == 0:
            break
    return moved_total


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_moments(rays_camera, depth, pixel_index, ids, normals_camera, n_planes, fx, fy):
    """Per-plane geometry of labelled points.

    The points are the pixels' rays times their depths, taken here pixel by pixel (the same
    products as ``rays_camera[pixel_index] * depth.flat[pixel_index][:, None]``, without the
    (N, 3) array and its two gathers).

    Args:
        rays_camera: (H·W, 3) camera-frame rays with unit z, row-major.
        depth: (H, W) depths [m].
        pixel_index: (N,) the points' pixels, indices into the flattened image.
        ids: (N,) plane id per point (-1: none).
        normals_camera: (P, 3) unit plane normals in the camera frame.
        n_planes: P.
        fx: focal length along x [px].
        fy: focal length along y [px].

    Returns:
        centroids (P, 3) camera frame [m], covariance eigenvalues (P, 3) ascending [m²],
        footprint areas (P,) [m²] (pixel footprints on the plane, incidence capped at cos 0.1).
    """
    sums = np.zeros((n_planes, _N_SUMS + 3))
    areas = np.zeros(n_planes)
    depth_flat = depth.ravel()
    n_points = ids.shape[0]
    i = 0
    while i < n_points:
        p = ids[i]
        if p < 0:
            i += 1
            continue
        # A run of points of one plane is summed in registers, starting from and going back
        # to its sums: the same additions in the same order as point by point into the array.
        n, s1, s2, s3 = sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3]
        s4, s5, s6, s7, s8, s9 = (
            sums[p, 4],
            sums[p, 5],
            sums[p, 6],
            sums[p, 7],
            sums[p, 8],
            sums[p, 9],
        )
        ref_x, ref_y, ref_z = sums[p, 10], sums[p, 11], sums[p, 12]
        area = areas[p]
        n0, n1, n2 = normals_camera[p, 0], normals_camera[p, 1], normals_camera[p, 2]
        while i < n_points and ids[i] == p:
            pixel = pixel_index[i]
            i += 1
            d = depth_flat[pixel]
            cx = rays_camera[pixel, 0] * d
            cy = rays_camera[pixel, 1] * d
            cz = rays_camera[pixel, 2] * d
            if n == 0.0:  # the plane's first point: the reference the moments are taken about
                ref_x = cx
                ref_y = cy
                ref_z = cz
            px = cx - ref_x
            py = cy - ref_y
            pz = cz - ref_z
            n += 1.0
            s1 += px
            s2 += py
            s3 += pz
            s4 += px * px
            s5 += px * py
            s6 += px * pz
            s7 += py * py
            s8 += py * pz
            s9 += pz * pz
            rng = math.sqrt(cx * cx + cy * cy + cz * cz)
            cos_inc = abs(cx * n0 + cy * n1 + cz * n2) / rng
            # Solid angle of a pixel (depth²/(fx·fy)·cos³ of the off-axis angle) times range² …
            area += cz * cz * cz / (rng * fx * fy * max(cos_inc, 0.1))
        sums[p, 0], sums[p, 1], sums[p, 2], sums[p, 3] = n, s1, s2, s3
        sums[p, 4], sums[p, 5], sums[p, 6], sums[p, 7], sums[p, 8], sums[p, 9] = (
            s4,
            s5,
            s6,
            s7,
            s8,
            s9,
        )
        sums[p, 10], sums[p, 11], sums[p, 12] = ref_x, ref_y, ref_z
        areas[p] = area
    centroids = np.zeros((n_planes, 3))
    eigen = np.zeros((n_planes, 3))
    cov = np.empty((3, 3))
    for p in range(n_planes):
        row = sums[p]
        n = row[0]
        if n == 0.0:
            continue
        mx = row[1] / n
        my = row[2] / n
        mz = row[3] / n
        centroids[p, 0] = mx + row[10]
        centroids[p, 1] = my + row[11]
        centroids[p, 2] = mz + row[12]
        cov[0, 0] = row[4] / n - mx * mx
        cov[0, 1] = cov[1, 0] = row[5] / n - mx * my
        cov[0, 2] = cov[2, 0] = row[6] / n - mx * mz
        cov[1, 1] = row[7] / n - my * my
        cov[1, 2] = cov[2, 1] = row[8] / n - my * mz
        cov[2, 2] = row[9] / n - mz * mz
        values = np.linalg.eigvalsh(cov)
        for k in range(3):  # element-wise: a row assignment compiles a shape check (~1.5 s)
            eigen[p, k] = values[k]
    return centroids, eigen, areas


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def segment_labels(valid, seg_rows, seg_starts, seg_stops, plane_of):
    """(H, W) int64 plane id per pixel from segment assignments: -1 none, -2 invalid."""
    height, width = valid.shape
    labels = np.full((height, width), -2, np.int64)
    for r in range(height):
        for c in range(width):
            if valid[r, c]:
                labels[r, c] = -1
    for i in range(seg_rows.shape[0]):
        p = plane_of[i]
        if p >= 0:
            for c in range(seg_starts[i], seg_stops[i]):
                labels[seg_rows[i], c] = p
    return labels


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def horizontal_sums(points, sigma_z, seg_rows, seg_starts, seg_stops, correlation):
    """(S, 6) sums of every segment for the horizontal model ``z = h``.

    Columns: Σw, Σw·z, Σw·z², n, Σw·x, Σw·y with w = 1/(correlation·sigma_z²) (points:
    (H, W, 3) points of the pixels in the tilt-corrected robot frame [m], sigma_z: their noise
    along z [m]). ``correlation`` (≥ 1, 1 for white noise) is the factor by which correlated
    noise inflates the variance of a mean over many pixels of a row: 1/Σw is then the squared
    standard error of the segment's mean height, and a pixel-level χ² is τ·(Σw·z² − (Σw·z)²/Σw).
    """
    n_seg = seg_rows.shape[0]
    out = np.empty((n_seg, 6))
    for i in range(n_seg):
        r = seg_rows[i]
        # Summed in registers from 0 in pixel order (the same sums as adding into the row).
        sw = swz = swzz = n = swx = swy = 0.0
        for c in range(seg_starts[i], seg_stops[i]):
            w = 1.0 / (correlation * sigma_z[r, c] * sigma_z[r, c])
            z = points[r, c, 2]
            sw += w
            swz += w * z
            swzz += w * z * z
            n += 1.0
            swx += w * points[r, c, 0]
            swy += w * points[r, c, 1]
        out[i, 0] = sw
        out[i, 1] = swz
        out[i, 2] = swzz
        out[i, 3] = n
        out[i, 4] = swx
        out[i, 5] = swy
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def grow_floors(
    seg_rows,
    seg_starts,
    seg_stops,
    seg_hsums,
    height,
    sigma_factor,
    chi_factor,
    tolerance_m,
    seed_min_pixels,
    correlation,
):
    """Region growing of horizontal floors (``z = h``, one parameter) over row segments.

    A segment is *level* when its points' heights scatter about their mean within
    ``chi_factor`` times their noise (RMS in sigma units). Level segments seed floors, the
    best-determined first (smallest standard error of the mean height), and floors grow
    breadth-first into touching level segments (rows above, below, same row) whose mean height
    agrees with the floor's running mean within ``sigma_factor`` standard errors (of both)
    plus ``tolerance_m``. The model cannot tilt, so it cannot creep up a staircase tread by
    tread as a free plane can when noise hides each small step.

    Args:
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        seg_hsums: (S, 4) sums of `horizontal_sums`.
        height: image height [px].
        sigma_factor: mean heights must agree within this many standard errors.
        chi_factor: a level segment's RMS height residual is at most this many sigma.
        tolerance_m: constant added to the height tolerance [m].
        seed_min_pixels: minimum length of a seed segment.
        correlation: the noise's variance inflation of means (`horizontal_sums`).

    Returns:
        (S,) int64 floor index of every segment, -1 for none; floors numbered in creation
        order.
    """
    n_seg = seg_rows.shape[0]
    floor_of = np.full(n_seg, -1, np.int64)
    if n_seg == 0:
        return floor_of
    row_first = _row_index(seg_rows, height)
    mean = np.zeros(n_seg)
    variance = np.full(n_seg, np.inf)  # squared standard error of the mean height
    level = np.zeros(n_seg, np.bool_)
    for i in range(n_seg):
        w, wz, wzz, n = seg_hsums[i, 0], seg_hsums[i, 1], seg_hsums[i, 2], seg_hsums[i, 3]
        if not w > 0.0 or n < 3.0:
            continue
        mean[i] = wz / w
        variance[i] = 1.0 / w
        chi2 = correlation * max(wzz - wz * mean[i], 0.0) / (n - 1.0)
        level[i] = chi2 <= chi_factor * chi_factor
    order = _stable_order(variance)
    queue = np.empty(n_seg, np.int64)
    n_floors = np.int64(0)  # not the literal 0: _merge_floors would compile for both
    for s in order:
        if not level[s] or floor_of[s] >= 0 or seg_stops[s] - seg_starts[s] < seed_min_pixels:
            continue
        label = n_floors
        n_floors += 1
        floor_of[s] = label
        total_w = seg_hsums[s, 0]
        total_wz = seg_hsums[s, 1]
        head = 0
        tail = 1
        queue[0] = s
        while head < tail:
            q = queue[head]
            head += 1
            rq = seg_rows[q]
            for rr in (rq - 1, rq, rq + 1):
                if rr < 0 or rr >= height:
                    continue
                gap = 1 if rr == rq else 0
                for t in range(row_first[rr], row_first[rr + 1]):
                    if floor_of[t] >= 0 or not level[t]:
                        continue
                    if not _overlap(seg_starts[q], seg_stops[q], seg_starts[t], seg_stops[t], gap):
                        continue
                    floor_mean = total_wz / total_w
                    tol = sigma_factor * math.sqrt(variance[t] + 1.0 / total_w) + tolerance_m
                    if abs(mean[t] - floor_mean) <= tol:
                        floor_of[t] = label
                        queue[tail] = t
                        tail += 1
                        total_w += seg_hsums[t, 0]
                        total_wz += seg_hsums[t, 1]
        # Members that took part while the mean was still uncertain and no longer fit the
        # final one leave the floor (the rows blending a tread with its riser).
        floor_mean = total_wz / total_w
        for k in range(tail):
            t = queue[k]
            tol = sigma_factor * math.sqrt(variance[t] + 1.0 / total_w) + tolerance_m
            if abs(mean[t] - floor_mean) > tol:
                floor_of[t] = -2
    for i in range(n_seg):
        if floor_of[i] == -2:
            floor_of[i] = -1
    _merge_floors(
        floor_of,
        n_floors,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_hsums,
        height,
        sigma_factor,
        tolerance_m,
    )
    return floor_of


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _merge_floors(
    floor_of,
    n_floors,
    seg_rows,
    seg_starts,
    seg_stops,
    seg_hsums,
    height,
    sigma_factor,
    tolerance_m,
):
    """Merge touching floors whose mean heights agree as growing requires (in place).

    Growing compares segments with the running mean, so a large level surface whose far rows
    sit a few millimetres off its near ones (residual tilt) can end up in two floors; their
    means still agree within the growing tolerance. Only floors of at least 3 segments merge
    (a row blending a tread with its riser must not bridge the two). Floors are renumbered in
    order of their first segment.
    """
    if n_floors < 2:
        return
    parent = np.arange(n_floors)
    total_w = np.zeros(n_floors)
    total_wz = np.zeros(n_floors)
    n_segments = np.zeros(n_floors, np.int64)
    for i in range(seg_rows.shape[0]):
        if floor_of[i] >= 0:
            total_w[floor_of[i]] += seg_hsums[i, 0]
            total_wz[floor_of[i]] += seg_hsums[i, 1]
            n_segments[floor_of[i]] += 1
    row_first = _row_index(seg_rows, height)
    for i in range(seg_rows.shape[0]):
        if floor_of[i] < 0:
            continue
        r = seg_rows[i]
        for rr in (r, r + 1):
            if rr >= height:
                continue
            gap = 1 if rr == r else 0
            for t in range(row_first[rr], row_first[rr + 1]):
                if floor_of[t] < 0 or t == i:
                    continue
                if not _overlap(seg_starts[i], seg_stops[i], seg_starts[t], seg_stops[t], gap):
                    continue
                a = floor_of[i]
                while parent[a] != a:
                    a = parent[a]
                b = floor_of[t]
                while parent[b] != b:
                    b = parent[b]
                if a == b or n_segments[a] < 3 or n_segments[b] < 3:
                    continue
                difference = abs(total_wz[a] / total_w[a] - total_wz[b] / total_w[b])
                tol = sigma_factor * math.sqrt(1.0 / total_w[a] + 1.0 / total_w[b]) + tolerance_m
                if difference <= tol:
                    keep, gone = min(a, b), max(a, b)
                    parent[gone] = keep
                    total_w[keep] += total_w[gone]
                    total_wz[keep] += total_wz[gone]
                    n_segments[keep] += n_segments[gone]
    new_id = np.full(n_floors, -1, np.int64)
    count = 0
    for i in range(seg_rows.shape[0]):
        if floor_of[i] < 0:
            continue
        a = floor_of[i]
        while parent[a] != a:
            a = parent[a]
        if new_id[a] < 0:
            new_id[a] = count
            count += 1
        floor_of[i] = new_id[a]


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def split_level(z, sigma_z, seg_rows, seg_starts, seg_stops, step_factor, min_pixels, correlation):
    """Split row segments where their height steps (for the horizontal model).

    A row running along a low step's side edge is one straight line in depth when noise
    hides the small depth jump there, but its heights then step by the step's height. Each
    segment is split, recursively, at the boundary with the largest difference of the
    weighted mean heights left and right of it, when that difference exceeds ``step_factor``
    of its standard error; pieces keep at least ``min_pixels`` pixels.

    Args:
        z: (H, W) heights of the pixels' points [m] (tilt-corrected robot frame).
        sigma_z: (H, W) their noise along z [m].
        seg_rows: (S,) row of each segment (output of `split_rows`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        step_factor: a height step of more than this many standard errors splits.
        min_pixels: shortest piece.
        correlation: the noise's variance inflation of means (`horizontal_sums`).

    Returns:
        rows, starts, stops of the pieces (int64, sorted by row then column).
    """
    width = z.shape[1]
    n_seg = seg_rows.shape[0]
    cap = n_seg + n_seg * (width // max(min_pixels, 1) + 1)
    rows = np.empty(cap, np.int64)
    starts = np.empty(cap, np.int64)
    stops = np.empty(cap, np.int64)
    count = 0
    stack = np.empty((width + 2, 2), np.int64)
    w_pre = np.zeros(width + 1)
    wz_pre = np.zeros(width + 1)
    for i in range(n_seg):
        r = seg_rows[i]
        stack[0, 0] = seg_starts[i]
        stack[0, 1] = seg_stops[i]
        top = 1
        while top > 0:  # depth first, left piece on top: pieces come out left to right
            top -= 1
            a = stack[top, 0]
            b = stack[top, 1]
            n = b - a
            for k in range(a, b):
                w = 1.0 / (sigma_z[r, k] * sigma_z[r, k])
                w_pre[k - a + 1] = w_pre[k - a] + w
                wz_pre[k - a + 1] = wz_pre[k - a] + w * z[r, k]
            best = 0.0
            split = -1
            for m in range(min_pixels, n - min_pixels + 1):
                w_left = w_pre[m]
                w_right = w_pre[n] - w_pre[m]
                difference = (wz_pre[n] - wz_pre[m]) / w_right - wz_pre[m] / w_left
                t = abs(difference) / math.sqrt(correlation * (1.0 / w_left + 1.0 / w_right))
                if t > best:
                    best = t
                    split = a + m
            if split > 0 and best > step_factor:
                stack[top, 0] = split
                stack[top, 1] = b
                stack[top + 1, 0] = a
                stack[top + 1, 1] = split
                top += 2
                continue
            rows[count] = r
            starts[count] = a
            stops[count] = b
            count += 1
    return rows[:count].copy(), starts[:count].copy(), stops[:count].copy()


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_segment_fit(seg_hsums, floor_of_segment, n_floors, tolerance_m, prior_extent_m):
    """Plane fits of every floor's segment mean heights (see `grow_floors`).

    Each floor's segments' mean heights are fitted by ``z = h + a·x + b·y`` (weights: their
    inverse squared standard errors, x and y the segments' weighted centroids relative to the
    floor's). The slopes have a prior of zero worth a floor ``prior_extent_m`` wide in every
    direction, so a floor a few rows deep does not get its slope across from noise.

    Returns:
        (F,) reduced chi² of the segment means about the plane, with ``tolerance_m`` added to
        every standard error (0 with fewer than 4 segments), and (F,) int64 segment counts.
    """
    n_seg = floor_of_segment.shape[0]
    w_sum = np.zeros(n_floors)
    x_sum = np.zeros(n_floors)
    y_sum = np.zeros(n_floors)
    n_segments = np.zeros(n_floors, np.int64)
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        w_sum[f] += w
        x_sum[f] += seg_hsums[i, 4]
        y_sum[f] += seg_hsums[i, 5]
        n_segments[f] += 1
    # Normal equations of (h, a, b): sums of w·[1, x, y]ᵀ[1, x, y] and w·m·[1, x, y].
    normal = np.zeros((n_floors, 6))  # 11, 1x, 1y, xx, xy, yy
    right = np.zeros((n_floors, 3))
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        m = seg_hsums[i, 1] / w
        x = seg_hsums[i, 4] / w - x_sum[f] / w_sum[f]
        y = seg_hsums[i, 5] / w - y_sum[f] / w_sum[f]
        normal[f, 0] += w
        normal[f, 1] += w * x
        normal[f, 2] += w * y
        normal[f, 3] += w * x * x
        normal[f, 4] += w * x * y
        normal[f, 5] += w * y * y
        right[f, 0] += w * m
        right[f, 1] += w * m * x
        right[f, 2] += w * m * y
    coefficients = np.zeros((n_floors, 3))
    for f in range(n_floors):
        s00 = normal[f, 0]
        s01 = normal[f, 1]
        s02 = normal[f, 2]
        s11 = normal[f, 3]
        s12 = normal[f, 4]
        s22 = normal[f, 5]
        ridge = s00 * prior_extent_m * prior_extent_m / 12.0
        s11 += ridge
        s22 += ridge
        c00 = s11 * s22 - s12 * s12
        c01 = s02 * s12 - s01 * s22
        c02 = s01 * s12 - s02 * s11
        det = s00 * c00 + s01 * c01 + s02 * c02
        if not det > 0.0:
            coefficients[f, 0] = right[f, 0] / s00
            continue
        c11 = s00 * s22 - s02 * s02
        c12 = s01 * s02 - s00 * s12
        c22 = s00 * s11 - s01 * s01
        r0 = right[f, 0]
        r1 = right[f, 1]
        r2 = right[f, 2]
        coefficients[f, 0] = (c00 * r0 + c01 * r1 + c02 * r2) / det
        coefficients[f, 1] = (c01 * r0 + c11 * r1 + c12 * r2) / det
        coefficients[f, 2] = (c02 * r0 + c12 * r1 + c22 * r2) / det
    chi2 = np.zeros(n_floors)
    for i in range(n_seg):
        f = floor_of_segment[i]
        if f < 0:
            continue
        w = seg_hsums[i, 0]
        x = seg_hsums[i, 4] / w - x_sum[f] / w_sum[f]
        y = seg_hsums[i, 5] / w - y_sum[f] / w_sum[f]
        residual = seg_hsums[i, 1] / w - (
            coefficients[f, 0] + coefficients[f, 1] * x + coefficients[f, 2] * y
        )
        chi2[f] += residual * residual / (1.0 / w + tolerance_m * tolerance_m)
    for f in range(n_floors):
        chi2[f] = chi2[f] / (n_segments[f] - 3) if n_segments[f] >= 4 else 0.0
    return chi2, n_segments


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_interior(labels, margin_px):
    """(H, W) bool: the pixels in the interior of their region.

    A pixel is interior when its neighbours up to ``margin_px`` away up, down, left and right
    all carry its own region (``labels`` >= 0; beyond the image border counts as another
    region). ``margin_px`` 0: every labelled pixel.
    """
    height, width = labels.shape
    out = np.zeros((height, width), np.bool_)
    if margin_px == 0:
        for r in range(height):
            for c in range(width):
                out[r, c] = labels[r, c] >= 0
        return out
    # Pixels within margin_px of the image border are never interior; the others' tests are
    # combined without branches (bitwise &), and margin 1 (the defaults) has no loop over the
    # distances: 2× faster than short-circuit tests in a loop, which numba can't unroll.
    for r in range(margin_px, height - margin_px):
        for c in range(margin_px, width - margin_px):
            f = labels[r, c]
            inside = (
                (f >= 0)
                & (labels[r - 1, c] == f)
                & (labels[r + 1, c] == f)
                & (labels[r, c - 1] == f)
                & (labels[r, c + 1] == f)
            )
            for k in range(2, margin_px + 1):
                inside = (
                    inside
                    & (labels[r - k, c] == f)
                    & (labels[r + k, c] == f)
                    & (labels[r, c - k] == f)
                    & (labels[r, c + k] == f)
                )
            out[r, c] = inside
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_depth(labels, margin_px):
    """(H, W) int64: how deep inside its region each pixel lies [px], at most ``margin_px``.

    A labelled pixel's depth is the largest ``k`` <= ``margin_px`` for which its neighbours up
    to ``k`` away up, down, left and right all carry its own region (beyond the image border
    counts as another region): 0 on the region's border, and ``region_depth(labels, m) >= m``
    is `region_interior` ``(labels, m)``. -1 where ``labels`` < 0.
    """
    height, width = labels.shape
    out = np.full((height, width), -1, np.int64)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f < 0:
                continue
            k = 0
            while k < margin_px:
                j = k + 1
                if (
                    r - j < 0
                    or r + j >= height
                    or c - j < 0
                    or c + j >= width
                    or labels[r - j, c] != f
                    or labels[r + j, c] != f
                    or labels[r, c - j] != f
                    or labels[r, c + j] != f
                ):
                    break
                k = j
            out[r, c] = k
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def foreign_rim(labels, inside, z, sigma_z, level_heights, factor):
    """(H, W) bool: the floor regions' rim pixels of a neighbouring surface.

    Labelled pixels outside ``inside`` farther from their region's level than
    ``factor`` times their noise along z (`segmentation._foreign_rim`, in one pass).

    Args:
        labels: (H, W) floor region of each pixel (-1 none, -2 no measurement).
        inside: (H, W) bool, the pixels within their region's border ring (`region_depth`
            >= 1; every labelled pixel when ``floor_height_margin_px`` is 0).
        z: (H, W) the pixels' heights [m].
        sigma_z: (H, W) their noise along z [m].
        level_heights: (F,) each region's level [m].
        factor: the tolerance in sigma.
    """
    height, width = labels.shape
    out = np.zeros((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f >= 0 and not inside[r, c]:
                out[r, c] = abs(z[r, c] - level_heights[f]) > factor * sigma_z[r, c]
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_statistics(
    labels,
    grown,
    interior,
    height_depth,
    height_margin_px,
    points,
    sigma_z,
    depth,
    rays,
    origin_z,
    fx,
    fy,
    n_floors,
    tolerance_m,
    roughness_m,
    roughness_min_extent_m,
):
    """Per-floor pixel statistics of the level regions.

    RMS and slope come from a region's *interior* pixels (`region_interior`) when it has any,
    else from all of them: a stereo matcher's window blends the pixels at a region's border
    with the neighbouring surface (a sill's far row reads 10-25 mm low, a tread's rows next to
    its riser too), which would count as roughness. The height comes from the grown pixels at
    least ``height_margin_px`` inside the region (``height_depth``, `region_depth`); a region
    with none (a narrow tread seen from afar) takes its deepest pixels, and only one without
    any pixel inside its border takes all: besides the blending, a region's border is where
    the growing selects one-sidedly (see `SegmentationParams.floor_height_margin_px`).

    Args:
        labels: (H, W) floor of each pixel after the fill (-1 none, -2 invalid).
        grown: (H, W) floor of each pixel before the fill (its segments').
        interior: (H, W) bool, the pixel is in its region's interior (`region_interior`).
        height_depth: (H, W) int, how deep inside its region each pixel lies, capped at
            ``height_margin_px`` (`region_depth` of ``labels``).
        height_margin_px: ``floor_height_margin_px``: the depth the height is taken from.
        points: (H, W, 3) points in the tilt-corrected robot frame [m].
        sigma_z: (H, W) their noise along z [m].
        depth: (H, W) measured depths [m].
        rays: (H, W, 3) rays in that frame with unit optical-axis component.
        origin_z: z of the camera centre [m].
        fx: focal length along x [px].
        fy: focal length along y [px].
        n_floors: F.
        tolerance_m: added to sigma_z for the RMS (exact data) [m].
        roughness_m: the surface's allowed unevenness, added to sigma_z (with
            ``tolerance_m``, in quadrature) for the RMS of regions whose minor extent is at
            least ``roughness_min_extent_m`` [m] (`SegmentationParams.floor_roughness_m`).
        roughness_min_extent_m: ``floor_roughness_min_extent_m`` [m].

    Returns:
        pixel counts (F,) int64, heights (F,) [m] (the grown pixels' level fit in inverse
        depth, `_level_height`), RMS height residual over all pixels (about the level fit of
        the same pixels) in units of sqrt(sigma_z² + tolerance_m²) (+ roughness_m², see
        above), squared residuals clipped at 9 (F,),
        footprint widths (F, 2) minor first [m] (sqrt(12)·std of the points moved onto the
        height along their rays) and footprint areas (F,) [m²] (pixel footprints on a
        horizontal plane, incidence capped at cos 0.1) and slopes (F,) ``|(a, b)|`` of the
        weighted fit ``z = h + a·x + b·y`` over the points moved onto the height (their x, y
        carry no depth noise).
    """
    height, width = labels.shape
    # Normal equations of the level model in inverse depth, q = ray_z·u with u = 1/(h − origin_z)
    # (see `_level_height`): Σw·ray_z², Σw·ray_z·q over the grown pixels: all of them, the
    # interior ones; and over those at each depth inside the region (0 .. height_margin_px).
    normal_sums = np.zeros((n_floors, 2, 2))
    depth_sums = np.zeros((n_floors, height_margin_px + 1, 2))
    has_interior = np.zeros(n_floors, np.bool_)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f >= 0 and interior[r, c]:
                has_interior[f] = True
            f = grown[r, c]
            if f >= 0:
                ray_z = rays[r, c, 2]
                d = depth[r, c]
                # 1/σ² of the inverse depth: depth noise σ_z/|ray_z| along the ray, over d².
                w = (d * d * ray_z / sigma_z[r, c]) ** 2
                term_0 = w * ray_z * ray_z
                term_1 = w * ray_z / d
                normal_sums[f, 0, 0] += term_0  # all grown pixels
                normal_sums[f, 0, 1] += term_1
                if interior[r, c]:
                    normal_sums[f, 1, 0] += term_0
                    normal_sums[f, 1, 1] += term_1
                k = height_depth[r, c]
                if k > 0:
                    depth_sums[f, k, 0] += term_0
                    depth_sums[f, k, 1] += term_1
    heights = np.zeros(n_floors)
    rms_heights = np.zeros(n_floors)  # the reference of the RMS: its own pixels' level
    for f in range(n_floors):
        # The deepest pixels up to the margin (a level's sums hold the pixels at that depth).
        k = height_margin_px
        while k > 0 and not depth_sums[f, k, 0] > 0.0:
            k -= 1
        if k > 0:
            heights[f] = _level_height(depth_sums[f, k, 0], depth_sums[f, k, 1], origin_z)
        else:
            heights[f] = _level_height(normal_sums[f, 0, 0], normal_sums[f, 0, 1], origin_z)
        k = 1 if normal_sums[f, 1, 0] > 0.0 else 0
        rms_heights[f] = _level_height(normal_sums[f, k, 0], normal_sums[f, k, 1], origin_z)
    used = np.zeros(n_floors, np.int64)
    counts = np.zeros(n_floors, np.int64)
    square = np.zeros(n_floors)
    rough_square = np.zeros(n_floors)  # the same against the noise with the unevenness
    rough_variance = tolerance_m**2 + roughness_m**2
    rough = roughness_m > 0.0  # the second sum only when the allowance is on
    moments = np.zeros((n_floors, 5))  # x, y, xx, xy, yy of the points on the height
    fit = np.zeros((n_floors, 9))  # weighted sums for the slope: 1 x y xx xy yy z xz yz
    areas = np.zeros(n_floors)
    # A run of pixels of one region along a row is summed in registers, starting from and
    # going back to the region's sums: the same additions in the same order as summing each
    # pixel into the arrays, without a store and a reload per sum and pixel.
    for r in range(height):
        c = 0
        while c < width:
            f = labels[r, c]
            if f < 0:
                c += 1
                continue
            n_f = counts[f]
            used_f = used[f]
            square_f = square[f]
            rough_square_f = rough_square[f]
            m0, m1, m2, m3, m4 = (
                moments[f, 0],
                moments[f, 1],
                moments[f, 2],
                moments[f, 3],
                moments[f, 4],
            )
            f0, f1, f2, f3, f4 = fit[f, 0], fit[f, 1], fit[f, 2], fit[f, 3], fit[f, 4]
            f5, f6, f7, f8 = fit[f, 5], fit[f, 6], fit[f, 7], fit[f, 8]
            area_f = areas[f]
            no_interior = not has_interior[f]
            height_f = heights[f]
            rms_height_f = rms_heights[f]
            while c < width and labels[r, c] == f:
                n_f += 1
                sigma = sigma_z[r, c]
                residual = points[r, c, 2] - rms_height_f
                counted = interior[r, c] or no_interior
                if counted:
                    used_f += 1
                    # Clipped at 3 sigma: a row of riser pixels joined to a tread is no roughness.
                    square_f += min(residual * residual / (sigma * sigma + tolerance_m**2), 9.0)
                    if rough:
                        rough_square_f += min(
                            residual * residual / (sigma * sigma + rough_variance), 9.0
                        )
                ray_z = rays[r, c, 2]
                d = depth[r, c]
                d_on = (height_f - origin_z) / ray_z if ray_z != 0.0 else -1.0
                if not d_on > 0.0:
                    d_on = d
                x = points[r, c, 0] + (d_on - d) * rays[r, c, 0]
                y = points[r, c, 1] + (d_on - d) * rays[r, c, 1]
                m0 += x
                m1 += y
                m2 += x * x
                m3 += x * y
                m4 += y * y
                # Weighted fit z = h + a·x + b·y over (x, y) on the height: free of the depth
                # noise, which moves a point along its ray in z and x, y together.
                w = 1.0 / (sigma * sigma) if counted else 0.0
                dz = residual
                f0 += w
                f1 += w * x
                f2 += w * y
                f3 += w * x * x
                f4 += w * x * y
                f5 += w * y * y
                f6 += w * dz
                f7 += w * x * dz
                f8 += w * y * dz
                norm = math.sqrt(rays[r, c, 0] ** 2 + rays[r, c, 1] ** 2 + ray_z * ray_z)
                area_f += d * d / (fx * fy * max(abs(ray_z), 0.1 * norm))
                c += 1
            counts[f] = n_f
            used[f] = used_f
            square[f] = square_f
            rough_square[f] = rough_square_f
            moments[f, 0], moments[f, 1], moments[f, 2], moments[f, 3], moments[f, 4] = (
                m0,
                m1,
                m2,
                m3,
                m4,
            )
            fit[f, 0], fit[f, 1], fit[f, 2], fit[f, 3], fit[f, 4] = f0, f1, f2, f3, f4
            fit[f, 5], fit[f, 6], fit[f, 7], fit[f, 8] = f5, f6, f7, f8
            areas[f] = area_f
    rms = np.zeros(n_floors)
    extents = np.zeros((n_floors, 2))
    slope = np.zeros(n_floors)
    for f in range(n_floors):
        n = counts[f]
        if n == 0:
            continue
        rms[f] = math.sqrt(square[f] / used[f])
        slope[f] = _fit_slope(fit[f])
        mx = moments[f, 0] / n
        my = moments[f, 1] / n
        cxx = moments[f, 2] / n - mx * mx
        cxy = moments[f, 3] / n - mx * my
        cyy = moments[f, 4] / n - my * my
        half = 0.5 * (cxx + cyy)
        root = math.sqrt(0.25 * (cxx - cyy) ** 2 + cxy * cxy)
        extents[f, 0] = math.sqrt(12.0 * max(half - root, 0.0))
        extents[f, 1] = math.sqrt(12.0 * max(half + root, 0.0))
        if rough and extents[f, 0] >= roughness_min_extent_m:
            rms[f] = math.sqrt(rough_square[f] / used[f])
    return counts, heights, rms, extents, areas, slope


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _level_height(sum_ray_z2, sum_ray_z_q, origin_z):
    """Height [m] of a level surface from its pixels' normal equations in inverse depth.

    A pixel's ray (unit optical-axis component, z component ``ray_z``) meets the plane
    ``z = h`` at depth ``(h − origin_z)/ray_z``: its inverse depth ``q = ray_z·u`` is linear in
    ``u = 1/(h − origin_z)``. A stereo camera's noise is additive and unbiased in inverse depth
    (disparity), so the weighted least squares ``u = Σw·ray_z·q / Σw·ray_z²`` is unbiased,
    and ``h = origin_z + 1/u`` only by the square of u's standard error relative to u (a
    region of n pixels: about σ_q²/(n·q²)). A weighted mean of the points' z is not: their
    depth ``1/q`` is biased by ``d·(σ_q/q)²``, and weights ``1/σ_z²`` from the measured depths
    (σ_z ∝ d²) favour the points measured too near — on a ground 1-2.5 m away under the depth
    mode's noise 0.3 mm too high, which the ground shift passed to every other surface.

    Args:
        sum_ray_z2: Σw·ray_z² of the pixels (w: 1/σ² of their inverse depth).
        sum_ray_z_q: Σw·ray_z·q.
        origin_z: z of the camera centre [m].

    Returns:
        The height [m]; NaN without pixels (or with rays parallel to the plane only).
    """
    if not sum_ray_z2 > 0.0 or sum_ray_z_q == 0.0:
        return np.nan
    return origin_z + sum_ray_z2 / sum_ray_z_q


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def _fit_slope(sums):
    """|(a, b)| of the weighted least squares ``z = h + a·x + b·y`` from sums (0 if singular)."""
    s0, sx, sy, sxx, sxy, syy, sz, sxz, syz = (
        sums[0],
        sums[1],
        sums[2],
        sums[3],
        sums[4],
        sums[5],
        sums[6],
        sums[7],
        sums[8],
    )
    # Centre x and y: the slope needs only the 2×2 system of the centred sums.
    cxx = sxx - sx * sx / s0
    cxy = sxy - sx * sy / s0
    cyy = syy - sy * sy / s0
    cxz = sxz - sx * sz / s0
    cyz = syz - sy * sz / s0
    det = cxx * cyy - cxy * cxy
    if not det > 1e-12 * max(cxx * cyy, 1e-300):
        return 0.0
    a = (cyy * cxz - cxy * cyz) / det
    b = (cxx * cyz - cxy * cxz) / det
    return math.hypot(a, b)


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_geometry(depth, unit_rays, rotation, origin, typical, min_noise_m):
    """Pixel rays, points and height noise in a rotated frame, for the horizontal model.

    Args:
        depth: (H, W) depths [m], NaN = none.
        unit_rays: (H·W, 3) camera-frame rays with unit z, row-major.
        rotation: 3×3 rotation from the camera frame to the frame.
        origin: (3,) camera centre in the frame [m].
        typical: (H, W) typical depth noise at each pixel's depth [m].
        min_noise_m: lower bound of the height noise [m].

    Returns:
        rays (H, W, 3) in the frame (unit optical-axis component), points (H, W, 3) [m] and
        sigma_z (H, W) [m] = max(typical·|ray_z|, min_noise_m) (depth noise lies along the
        ray); points and sigma_z NaN where there is no depth.
    """
    height, width = depth.shape
    rays = np.empty((height, width, 3))
    points = np.empty((height, width, 3))
    sigma_z = np.empty((height, width))
    for r in range(height):
        for c in range(width):
            i = r * width + c
            for k in range(3):
                rays[r, c, k] = (
                    rotation[k, 0] * unit_rays[i, 0]
                    + rotation[k, 1] * unit_rays[i, 1]
                    + rotation[k, 2] * unit_rays[i, 2]
                )
            d = depth[r, c]
            if d == d:
                for k in range(3):
                    points[r, c, k] = origin[k] + d * rays[r, c, k]
                sigma_z[r, c] = max(typical[r, c] * abs(rays[r, c, 2]), min_noise_m)
            else:
                for k in range(3):
                    points[r, c, k] = np.nan
                sigma_z[r, c] = np.nan
    return rays, points, sigma_z


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_points(
    pixel_index,
    floor_labels,
    floor_of_region,
    ground_m,
    rays,
    depth,
    typical,
    origin,
    relabel_factor,
    snap_factor,
):
    """Corrected points and floor heights of the valid pixels (see `segment_depth`).

    A pixel in no level region (not even one that failed the floor tests: it has a height of
    its own) whose depth lies within ``relabel_factor`` sigma (``typical``) of where its ray
    meets the ground height ``ground_m`` becomes a ground point (ground_m NaN or factor 0:
    none). A floor point whose ray meets its height going down within
    ``snap_factor`` sigma of its depth is moved there along the ray; one that does not loses
    its floor label (factor 0: points stay, labels too).

    ``pixel_index`` (N,) are the valid pixels' indices into the flattened image in ascending
    order (``np.flatnonzero``).

    Returns:
        (N, 3) points [m], (N,) floor heights [m] (NaN: not floor) and (N,) the pixels' floor
        regions (``np.take(floor_labels, pixel_index)``, read on the way).
    """
    n = pixel_index.shape[0]
    width = depth.shape[1]
    points = np.empty((n, 3))
    heights = np.full(n, np.nan)
    regions = np.empty(n, floor_labels.dtype)
    r = 0
    for i in range(n):
        # pixel_index ascends (row-major order): the row follows by steps, no division.
        while pixel_index[i] >= (r + 1) * width:
            r += 1
        c = pixel_index[i] - r * width
        d = depth[r, c]
        ray_z = rays[r, c, 2]
        tol = typical[r, c]
        f = floor_labels[r, c]
        regions[i] = f
        h = floor_of_region[f] if f >= 0 else np.nan
        if (
            f == -1
            and relabel_factor > 0.0
            and ground_m == ground_m
            and ray_z < 0.0
            and abs(d - (ground_m - origin[2]) / ray_z) <= relabel_factor * tol
        ):
            h = ground_m
        if h == h and snap_factor > 0.0:
            d_on = (h - origin[2]) / ray_z if ray_z < 0.0 else np.inf
            if abs(d - d_on) <= snap_factor * tol:
                d = d_on
            else:
                h = np.nan
        heights[i] = h
        for k in range(3):
            points[i, k] = origin[k] + d * rays[r, c, k]
    return points, heights, regions


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def renumber_planes(labels, grown_labels, pixel_index, keep):
    """Planes kept renumbered in creation order, in one pass over the image.

    Args:
        labels: (H, W) plane of each pixel after the fill (-1 none, -2 no measurement).
        grown_labels: (H, W) the same before the fill (the grown segments only).
        pixel_index: (N,) the valid pixels' indices into the flattened image.
        keep: (P,) bool, the planes kept.

    Returns:
        (H, W) ``labels`` renumbered (a dissolved plane's pixels -1), (H, W) ``grown_labels``
        renumbered, (N,) the valid pixels' renumbered labels and (N,) grown labels, and the
        (K,) pixels of each kept plane (its valid pixels' labels).
    """
    n_planes = keep.shape[0]
    new_id = np.full(n_planes, -1, dtype=np.int64)
    n_kept = 0
    for p in range(n_planes):
        if keep[p]:
            new_id[p] = n_kept
            n_kept += 1
    height, width = labels.shape
    renumbered = np.empty((height, width), dtype=np.int64)
    grown = np.empty((height, width), dtype=np.int64)
    for r in range(height):
        for c in range(width):
            label = labels[r, c]
            renumbered[r, c] = new_id[label] if label >= 0 else label
            label = grown_labels[r, c]
            grown[r, c] = new_id[label] if label >= 0 else label
    n = pixel_index.shape[0]
    plane_ids = np.empty(n, dtype=np.int64)
    grown_ids = np.empty(n, dtype=np.int64)
    counts = np.zeros(n_kept, dtype=np.int64)
    for i in range(n):
        r = pixel_index[i] // width
        c = pixel_index[i] - r * width
        plane_ids[i] = renumbered[r, c]
        grown_ids[i] = grown[r, c]
        if plane_ids[i] >= 0:
            counts[plane_ids[i]] += 1
    return renumbered, grown, plane_ids, grown_ids, counts


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_heights(floor_of_segment, seg_hsums, n_floors):
    """(F,) each level region's height: its grown segments' weighted mean height [m].

    ``Σ sums[:, 1] / Σ sums[:, 0]`` over the region's segments in segment order (as
    ``np.bincount`` sums; `horizontal_sums` columns: weight, weighted height); NaN for a
    region without segments.
    """
    weighted = np.zeros(n_floors)
    weights = np.zeros(n_floors)
    for i in range(floor_of_segment.shape[0]):
        f = floor_of_segment[i]
        if f >= 0:
            weighted[f] += seg_hsums[i, 1]
            weights[f] += seg_hsums[i, 0]
    return weighted / weights


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def region_noise_ratio(labels, sigma, typical, n_regions):
    """(F,) mean of ``sigma / typical`` over each region's pixels (0 for a region without any).

    `mapper.segmentation.segment_depth`'s roughness test of the floors
    (`SegmentationParams.floor_max_noise_ratio`): ``sigma`` is the local noise estimate
    (`local_noise_depth_m`, from second differences of inverse depth in a box reaching
    ``noise_window_px`` columns and a row beyond the pixel, so also over pixels the region left
    out), ``typical`` the sensor model's (or the image's) noise at the same depth.

    Args:
        labels: (H, W) region of each pixel (-1 none, -2 no measurement).
        sigma: (H, W) local depth noise [m] (NaN: none).
        typical: (H, W) typical depth noise at the pixel's depth [m] (NaN: none).
        n_regions: F.
    """
    height, width = labels.shape
    total = np.zeros(n_regions)
    count = np.zeros(n_regions)
    for r in range(height):
        for c in range(width):
            f = labels[r, c]
            if f < 0:
                continue
            ratio = sigma[r, c] / typical[r, c]
            if ratio == ratio:  # not NaN
                total[f] += ratio
                count[f] += 1.0
    out = np.zeros(n_regions)
    for f in range(n_regions):
        if count[f] > 0.0:
            out[f] = total[f] / count[f]
    return out


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def floor_verdict(
    counts,
    n_segments,
    extents,
    slope,
    rms_ratio,
    chi2,
    min_pixels,
    min_extent_m,
    max_slope,
    max_rms_ratio,
    max_segment_chi2,
):
    """(F,) bool: the level regions that are floors (`mapper.segmentation.floor_regions`).

    At least ``min_pixels`` pixels in 3 or more segments, a minor extent of ``min_extent_m``,
    a slope of at most ``max_slope`` (tan), an RMS ratio of at most ``max_rms_ratio`` (0: no
    test) and a segment χ² of at most ``max_segment_chi2·min(1 + 3·sqrt(2/dof), 2.5)``,
    dof = max(segments − 3, 1) (0: no test).
    """
    n = counts.shape[0]
    is_floor = np.empty(n, dtype=np.bool_)
    for f in range(n):
        dof = max(n_segments[f] - 3, 1)
        is_floor[f] = (
            counts[f] >= min_pixels
            and n_segments[f] >= 3
            and extents[f, 0] >= min_extent_m
            and slope[f] <= max_slope
            and (max_rms_ratio == 0.0 or rms_ratio[f] <= max_rms_ratio)
            and (
                max_segment_chi2 == 0.0
                or chi2[f] <= max_segment_chi2 * min(1.0 + 3.0 * math.sqrt(2.0 / dof), 2.5)
            )
        )
    return is_floor


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


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def level_regions(
    z,
    sigma_z,
    points,
    rays,
    depth,
    seg_rows,
    seg_starts,
    seg_stops,
    origin_z,
    fx,
    fy,
    step_factor,
    min_segment_pixels,
    correlation,
    grow_factor,
    chi_factor,
    height_tolerance_m,
    seed_min_pixels,
    fill_factor,
    tolerance_floor_m,
    fill_passes,
    edge_margin_px,
    height_margin_px,
    snap_factor,
    min_plane_pixels,
    min_extent_m,
    max_slope,
    max_rms_ratio,
    max_segment_chi2,
    roughness_m,
    roughness_min_extent_m,
):
    """The floor stage of `mapper.segmentation.floor_regions` in one call (its kernels in turn).

    `split_level`, `horizontal_sums`, `grow_floors`, `segment_labels`, `level_heights`,
    `fill_pixels` (grown heights, no pixel fill without regions or passes), `region_interior`
    (edge margin), `region_depth` (height margin), `foreign_rim` (with ``snap_factor`` > 0),
    `floor_statistics`, `floor_segment_fit` and `floor_verdict`, with the same arguments: one
    dispatch and no intermediate arrays handed to Python (the same results bit for bit).

    Args:
        z: (H, W) C-contiguous heights of the pixels in the tilt-corrected frame [m].
        sigma_z: (H, W) their noise along z [m].
        points: (H, W, 3) the pixels' points in that frame [m] (NaN: no depth).
        rays: (H, W, 3) pixel rays in that frame with unit optical-axis component.
        depth: (H, W) measured depths [m], NaN = none.
        seg_rows: (S,) row of each row segment (`split_rows`, `propagate_breaks`).
        seg_starts: (S,) first column of each segment.
        seg_stops: (S,) column after the last of each segment.
        origin_z: z of the camera centre in that frame [m].
        fx: focal length along x [px] (pixel footprints).
        fy: focal length along y [px].
        step_factor: ``edge_sigma_factor`` (`split_level`).
        min_segment_pixels: shorter level pieces are no segments.
        correlation: ``noise_correlation_factor``.
        grow_factor: ``grow_sigma_factor`` (`grow_floors`).
        chi_factor: ``rms_sigma_factor`` (`grow_floors`).
        height_tolerance_m: ``floor_height_tolerance_m`` [m].
        seed_min_pixels: minimum length of each seed segment.
        fill_factor: ``fill_sigma_factor`` (`fill_pixels`).
        tolerance_floor_m: constant added to every tolerance [m].
        fill_passes: how many pixels deep leftover pixels may join a region.
        edge_margin_px: ``floor_edge_margin_px`` (`region_interior`).
        height_margin_px: ``floor_height_margin_px``.
        snap_factor: ``floor_snap_sigma_factor`` (`foreign_rim`; 0: no rim left out).
        min_plane_pixels: a floor's least pixels (`floor_verdict`).
        min_extent_m: ``min_plane_extent_m`` [m] (also `floor_segment_fit`'s prior extent).
        max_slope: tangent of ``floor_max_normal_angle_deg``.
        max_rms_ratio: ``floor_max_rms_ratio`` (0: no test).
        max_segment_chi2: ``floor_max_segment_chi2`` (0: no test).
        roughness_m: ``floor_roughness_m`` [m] (`floor_statistics`).
        roughness_min_extent_m: ``floor_roughness_min_extent_m`` [m].

    Returns:
        (H, W) floor region of each pixel (-1 none, -2 no measurement); per region (F,)
        pixel counts, heights [m], RMS ratios, (F, 2) extents [m], areas [m²] and is-floor.
    """
    level_rows, level_starts, level_stops = split_level(
        z, sigma_z, seg_rows, seg_starts, seg_stops, step_factor, min_segment_pixels, correlation
    )
    sums = horizontal_sums(points, sigma_z, level_rows, level_starts, level_stops, correlation)
    height, width = depth.shape
    floor_of_segment = grow_floors(
        level_rows,
        level_starts,
        level_stops,
        sums,
        height,
        grow_factor,
        chi_factor,
        height_tolerance_m,
        seed_min_pixels,
        correlation,
    )
    n_floors = np.int64(0)  # not a literal 0: one signature of the callees
    for i in range(floor_of_segment.shape[0]):
        n_floors = max(n_floors, floor_of_segment[i] + 1)
    measured = np.empty((height, width), np.bool_)
    for r in range(height):
        for c in range(width):
            measured[r, c] = np.isfinite(depth[r, c])
    grown = segment_labels(measured, level_rows, level_starts, level_stops, floor_of_segment)
    labels = grown
    grown_heights = level_heights(floor_of_segment, sums, n_floors)
    if n_floors > 0 and fill_passes > 0:
        labels = grown.copy()
        level_model = np.zeros((n_floors, 3))
        for f in range(n_floors):
            level_model[f, 2] = grown_heights[f]
        fill_pixels(
            z,
            np.zeros(width),
            np.zeros(height),
            labels,
            sigma_z,
            level_model,
            fill_factor,
            tolerance_floor_m,
            fill_passes,
            _LEVEL_MODEL,
        )
    interior = region_interior(labels, edge_margin_px)
    # The height comes from the pixels deepest inside, up to the margin; the rim a neighbouring
    # surface may have lent a region is its border ring (the margin's first pixel).
    height_depth = region_depth(labels, height_margin_px)
    if n_floors > 0 and snap_factor > 0.0:
        ring_inside = height_depth >= min(height_margin_px, 1)
        rim = foreign_rim(labels, ring_inside, z, sigma_z, grown_heights, snap_factor)
        interior = interior & ~rim
    counts, heights, rms, extents, areas, slope = floor_statistics(
        labels,
        grown,
        interior,
        height_depth,
        height_margin_px,
        points,
        sigma_z,
        depth,
        rays,
        origin_z,
        fx,
        fy,
        n_floors,
        tolerance_floor_m,
        roughness_m,
        roughness_min_extent_m,
    )
    chi2, n_segments = floor_segment_fit(
        sums, floor_of_segment, n_floors, height_tolerance_m, min_extent_m
    )
    is_floor = floor_verdict(
        counts,
        n_segments,
        extents,
        slope,
        rms,
        chi2,
        min_plane_pixels,
        min_extent_m,
        max_slope,
        max_rms_ratio,
        max_segment_chi2,
    )
    return labels, counts, heights, rms, extents, areas, is_floor


@numba.njit(cache=True, no_cfunc_wrapper=True, nogil=True, error_model="numpy")
def plane_labels(
    inv_depth,
    valid,
    cx,
    cy,
    fx,
    fy,
    noise_window,
    min_noise_m,
    noise_cap_factor,
    model_inv_sigma,
    split_factor,
    split_rms_factor,
    edge_window,
    edge_factor,
    tolerance_floor_m,
    min_segment_pixels,
    correlation,
    break_passes,
    break_factor,
    break_reach,
    grow_factor,
    rms_factor,
    seed_min_pixels,
    reassign_passes,
    fill_factor,
    fill_passes,
):
    """The planes stage of `mapper.segmentation.segment_depth` in one call (its kernels in turn).

    The columns' and rows' normalised image coordinates ``(i − c)/f``, `local_noise_depth_m`,
    `split_rows`, up to ``break_passes`` rounds of `propagate_breaks` (until a round splits
    nothing), `segment_sums`, `grow_planes`, `reassign_segments`, `segment_labels`,
    `plane_fits` and `fill_pixels` (with planes and passes), with the same arguments: one
    dispatch and no intermediate arrays handed to Python (the same results bit for bit).

    Args:
        inv_depth: (H, W) inverse depth [1/m] (NaN: none).
        valid: (H, W) bool, the measured pixels.
        cx: principal point column [px].
        cy: principal point row [px].
        fx: focal length along x [px].
        fy: focal length along y [px].
        noise_window: ``noise_window_px``.
        min_noise_m: ``min_noise_m`` [m].
        noise_cap_factor: ``noise_cap_factor``.
        model_inv_sigma: the stereo model's inverse-depth std [1/m] (0: none).
        split_factor: ``split_sigma_factor``.
        split_rms_factor: ``split_rms_sigma_factor``.
        edge_window: ``edge_window_px``.
        edge_factor: ``edge_sigma_factor``.
        tolerance_floor_m: ``tolerance_floor_m`` [m].
        min_segment_pixels: ``min_segment_pixels``.
        correlation: ``noise_correlation_factor``.
        break_passes: ``break_passes``.
        break_factor: ``break_sigma_factor``.
        break_reach: ``break_reach_px``.
        grow_factor: ``grow_sigma_factor``.
        rms_factor: ``rms_sigma_factor``.
        seed_min_pixels: ``seed_min_pixels``.
        reassign_passes: ``reassign_passes``.
        fill_factor: ``fill_sigma_factor``.
        fill_passes: ``fill_passes``.

    Returns:
        (W,) x and (H,) y of the columns and rows, (H, W) typical noise [m] (the range
        profile's, or the sensor model's), (H, W) local noise [m] (`local_noise_depth_m`),
        the (S,) rows, starts and stops of the row segments, (H, W) plane of each
        pixel after the fill and (H, W) before it (-1 none, -2 no measurement), the (P, 13)
        plane fits and (P,) their pixels (before the fill).
    """
    height, width = inv_depth.shape
    x = np.empty(width)
    for c in range(width):
        x[c] = (c - cx) / fx
    y = np.empty(height)
    for r in range(height):
        y[r] = (r - cy) / fy
    sigma, typical_sigma = local_noise_depth_m(
        inv_depth, noise_window, min_noise_m, noise_cap_factor, model_inv_sigma
    )
    seg_rows, seg_starts, seg_stops, seg_table = split_rows(
        inv_depth,
        x,
        sigma,
        split_factor,
        split_rms_factor,
        edge_window,
        edge_factor,
        tolerance_floor_m,
        min_segment_pixels,
        correlation,
    )
    # Rows to test in the next round of `propagate_breaks`: every row first, then those
    # next to (or in) a row that split (the others would split nothing again).
    check_rows = np.ones(height, np.bool_)
    for _ in range(break_passes):
        n_before = seg_rows.shape[0]
        seg_rows, seg_starts, seg_stops, seg_table, split_in = propagate_breaks(
            inv_depth,
            x,
            sigma,
            seg_rows,
            seg_starts,
            seg_stops,
            seg_table,
            check_rows,
            edge_window,
            break_factor,
            tolerance_floor_m,
            min_segment_pixels,
            break_reach,
            correlation,
        )
        if seg_rows.shape[0] == n_before:
            break
        for r in range(height):
            check_rows[r] = (
                split_in[r] or (r > 0 and split_in[r - 1]) or (r + 1 < height and split_in[r + 1])
            )
    seg_sums = segment_sums(inv_depth, x, y, seg_rows, seg_starts, seg_stops)
    plane_of_segment = grow_planes(
        inv_depth,
        x,
        y,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_table,
        seg_sums,
        grow_factor,
        rms_factor,
        tolerance_floor_m,
        seed_min_pixels,
    )
    reassign_segments(
        inv_depth,
        x,
        y,
        seg_rows,
        seg_starts,
        seg_stops,
        seg_table,
        seg_sums,
        plane_of_segment,
        grow_factor,
        rms_factor,
        tolerance_floor_m,
        reassign_passes,
    )
    labels = segment_labels(valid, seg_rows, seg_starts, seg_stops, plane_of_segment)
    n_planes = np.int64(0)  # not a literal 0: one signature of the callees
    for i in range(plane_of_segment.shape[0]):
        n_planes = max(n_planes, plane_of_segment[i] + 1)
    plane_table, counts = plane_fits(inv_depth, x, y, labels, n_planes)
    grown_labels = labels.copy()
    if n_planes > 0 and fill_passes > 0:
        fill_pixels(
            inv_depth,
            x,
            y,
            labels,
            sigma,
            plane_table,
            fill_factor,
            tolerance_floor_m,
            fill_passes,
            _INVERSE_DEPTH_MODEL,
        )
    return (
        x,
        y,
        typical_sigma,
        sigma,
        seg_rows,
        seg_starts,
        seg_stops,
        labels,
        grown_labels,
        plane_table,
        counts,
    )
