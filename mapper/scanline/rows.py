"""Every image row cut into straight segments in inverse depth (image frame; tolerances [m]).

A straight 3D line on a plane has an inverse depth ``1/d = a + b·x`` affine in the normalised
image x = (u − cx)/fx along an image row (`mapper.scanline.planes`: why inverse depth).

`split_rows`: every row is cut into runs of valid pixels and each run recursively split until a
weighted line fits every pixel within ``split_factor·sigma + floor``, its RMS residual is within
``rms_factor·sigma`` and no depth step shows in its residuals (mean residuals in windows either
side of a pixel boundary differ by at most ``edge_factor`` standard errors). Splits go to the
step, else the outlier, else the residuals' CUSUM peak. `propagate_breaks` then splits, at a
lower threshold, where the rows above or below break.

The segments: rows, starts, stops (stop exclusive; int64, sorted by row then column) and an
(S, 3) table of each one's line (p, q of ``1/d = p + q·x``) and mean depth noise [m]; the
planes (`mapper.scanline.planes`) and the level regions (`mapper.scanline.levels`) grow over
them.
"""

from __future__ import annotations

import math

import numba
import numpy as np


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
